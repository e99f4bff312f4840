"""Newton's method as a PETSc SNES, configured from the options database.

Defaults (each overridable on the command line, e.g. ``-pc_type cholesky``):
``-ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps`` (MUMPS LDL^T
of the symmetric indefinite tangent; ``-pc_type lu`` for LU), full Newton
steps (``-snes_linesearch_type basic``, as code_aster), MUMPS null-pivot
detection off (``-mat_mumps_icntl_24 0``, as the user asked).

The Jacobian is stored as SBAIJ (upper triangle only: the tangent is symmetric)
when the preconditioner factors symmetrically (``-pc_type cholesky``, the
default), as AIJ otherwise; ``-mat_type aij`` or ``sbaij`` chooses.  SBAIJ halves
the matrix and lets MUMPS read it without a copy of its values.

Convergence follows code_aster's RESI_GLOB_RELA: the residual norm relative to
the norm of the applied loads (external forces and the forces of imposed
displacements), so that a Newton solve that starts converged stops at once
without factorising.  ``-snes_rtol`` overrides RESI_GLOB_RELA, ``-snes_max_it``
ITER_GLOB_MAXI; ``-snes_atol`` still applies.
"""
from xfemcontact._petsc import PETSc
from xfemcontact.errors import XfcError

DEFAULT_OPTIONS = {
    "ksp_type": "preonly",
    "pc_type": "cholesky",      # MUMPS LDL^T: the STANDARD contact tangent is symmetric
    "pc_factor_mat_solver_type": "mumps",
    "snes_linesearch_type": "basic",
    "mat_mumps_icntl_24": "0",
}


def set_default_options(prefix=""):
    """Put our defaults in the options database where the user gave nothing."""
    opts = PETSc.Options()
    for key, value in DEFAULT_OPTIONS.items():
        if not opts.hasName(prefix + key):
            opts.setValue(prefix + key, value)


#: preconditioners that factor a symmetric matrix (SBAIJ storage by default)
SYMMETRIC_PCS = ("cholesky", "icc")


def matrix_format(prefix=""):
    """``"sbaij"`` or ``"aij"``: the Jacobian's storage (see the module docstring)."""
    set_default_options(prefix)
    opts = PETSc.Options()
    given = (opts.getString(prefix + "mat_type", "") or "").lower()
    if given:
        if given in ("sbaij", "seqsbaij", "mpisbaij"):
            return "sbaij"
        if given in ("aij", "seqaij", "mpiaij"):
            return "aij"
        raise XfcError(f"-{prefix}mat_type {given}: the Jacobian is assembled as aij or sbaij",
                       collective=True)
    return "sbaij" if opts.getString(prefix + "pc_type", "") in SYMMETRIC_PCS else "aij"


class LoadRelativeTest:
    """SNES convergence test: ``|R| <= rtol * |F_load|`` (2-norms of free dofs).

    ``load_norm`` is a callable giving the current load norm; when it is zero
    the absolute tolerance decides.
    """

    def __init__(self, load_norm):
        self.load_norm = load_norm
        self.history = []

    def __call__(self, snes, its, norms):
        xnorm, ynorm, fnorm = norms
        self.history.append(fnorm)
        rtol, atol, stol, max_it = snes.getTolerances()
        ref = self.load_norm()
        if fnorm != fnorm:    # NaN
            return PETSc.SNES.ConvergedReason.DIVERGED_FNORM_NAN
        if fnorm <= atol:
            return PETSc.SNES.ConvergedReason.CONVERGED_FNORM_ABS
        if ref > 0.0 and fnorm <= rtol * ref:
            return PETSc.SNES.ConvergedReason.CONVERGED_FNORM_RELATIVE
        if its >= max_it:
            return PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT
        return PETSc.SNES.ConvergedReason.ITERATING


def create_snes(comm, residual, jacobian, J, f, resi_glob_rela, iter_glob_maxi, load_norm, prefix=""):
    """A Newton SNES on our callbacks with code_aster's convergence criterion.

    ``residual(snes, x, f)`` and ``jacobian(snes, x, J, P)`` follow petsc4py's
    conventions; ``J`` is the Jacobian matrix, ``f`` a work vector.
    """
    set_default_options(prefix)
    snes = PETSc.SNES().create(comm=comm)
    snes.setOptionsPrefix(prefix)
    snes.setType(PETSc.SNES.Type.NEWTONLS)
    snes.setFunction(residual, f)
    snes.setJacobian(jacobian, J, J)
    snes.setTolerances(rtol=resi_glob_rela, atol=1e-50, max_it=iter_glob_maxi)
    test = LoadRelativeTest(load_norm)
    snes.setConvergenceTest(test)
    snes.setFromOptions()
    return snes, test
