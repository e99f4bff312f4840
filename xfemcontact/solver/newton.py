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
from __future__ import annotations

import difflib
import re
from typing import Any, Callable, Sequence

import numpy as np

from xfemcontact._petsc import PETSc
from xfemcontact.errors import XfcError

DEFAULT_OPTIONS = {
    "ksp_type": "preonly",
    "pc_type": "cholesky",      # MUMPS LDL^T: the STANDARD contact tangent is symmetric
    "pc_factor_mat_solver_type": "mumps",
    "snes_linesearch_type": "basic",
    "mat_mumps_icntl_24": "0",
    # SuperLU_DIST (-pc_type lu -pc_factor_mat_solver_type superlu_dist) pivots statically:
    # without this the zero diagonal block of the contact multipliers stops its factorisation
    # (DIVERGED_PCSETUP_FAILED on every contact case); with it a tiny pivot is replaced and
    # Newton, whose residual is exact, corrects the perturbed factor (cases/validation/
    # frictionless.toml: 8 Newton iterations, as with MUMPS)
    "mat_superlu_dist_replacetinypivot": "1",
}


#: options database keys holding our defaults (not the user's)
_DEFAULTED: set[str] = set()


def set_default_options(prefix: str = "") -> None:
    """Put our defaults in the options database where the user gave nothing."""
    opts = PETSc.Options()
    for key, value in DEFAULT_OPTIONS.items():
        if not opts.hasName(prefix + key):
            opts.setValue(prefix + key, value)
            _DEFAULTED.add(prefix + key)


def user_value(key: str) -> str | None:
    """The value the user gave to the option ``key`` (without the dash), None when it
    is absent or ours (:data:`DEFAULT_OPTIONS`)."""
    opts = PETSc.Options()
    if key in _DEFAULTED or not opts.hasName(key):
        return None
    return opts.getString(key)


#: preconditioners that factor a symmetric matrix (SBAIJ storage by default)
SYMMETRIC_PCS = ("cholesky", "icc")


def matrix_format(prefix: str = "") -> str:
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
    the absolute tolerance decides.  ``settled`` (optional) is a callable of the
    iterate: False while the statuses the residual would take at it differ from
    those its Jacobian used (a semi-smooth Newton has converged only when its
    active set has stopped changing); Newton then goes on.  ``scaled`` (optional) is
    a callable of the residual Vec giving the norm the relative test uses instead of
    the 2-norm (rows of other units weighed into forces).
    """

    def __init__(self, load_norm: Callable[[], float], settled: Callable[[PETSc.Vec, float], bool] | None = None,
                 scaled: Callable[[PETSc.Vec], float] | None = None) -> None:
        self.load_norm = load_norm
        self.settled = settled
        self.scaled = scaled
        self.history: list[float] = []
        #: the next solve takes at least one iteration (PETSc's SNESSetForceIteration, which
        #: only its default test reads)
        self.force_iteration = False

    def __call__(self, snes: PETSc.SNES, its: int, norms: tuple[float, float, float]) -> int:
        xnorm, ynorm, fnorm = norms
        self.history.append(fnorm)
        rtol, atol, stol, max_it = snes.getTolerances()
        ref = self.load_norm()
        if fnorm != fnorm:    # NaN
            return PETSc.SNES.ConvergedReason.DIVERGED_FNORM_NAN
        converged = None
        if fnorm <= atol:
            converged = PETSc.SNES.ConvergedReason.CONVERGED_FNORM_ABS
        elif ref > 0.0 and fnorm <= rtol * ref and (
                self.scaled is None or self.scaled(snes.getFunction()[0]) <= rtol * ref):
            converged = PETSc.SNES.ConvergedReason.CONVERGED_FNORM_RELATIVE
        if its == 0 and self.force_iteration:
            converged = None
        if converged is not None and (self.settled is None or
                                      self.settled(snes.getSolution(), max(rtol * ref, atol))):
            return converged
        if its >= max_it:
            return PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT
        return PETSc.SNES.ConvergedReason.ITERATING


def create_snes(comm: PETSc.Comm, residual: Callable[[PETSc.SNES, PETSc.Vec, PETSc.Vec], None],
                jacobian: Callable[[PETSc.SNES, PETSc.Vec, PETSc.Mat, PETSc.Mat], None],
                J: PETSc.Mat, f: PETSc.Vec, resi_glob_rela: float, iter_glob_maxi: int,
                load_norm: Callable[[], float], prefix: str = "",
                settled: Callable[[PETSc.Vec, float], bool] | None = None,
                scaled: Callable[[PETSc.Vec], float] | None = None) -> tuple[PETSc.SNES, LoadRelativeTest]:
    """A Newton SNES on our callbacks with code_aster's convergence criterion.

    ``residual(snes, x, f)`` and ``jacobian(snes, x, J, P)`` follow petsc4py's
    conventions; ``J`` is the Jacobian matrix, ``f`` a work vector; ``settled``,
    ``scaled``: see :class:`LoadRelativeTest`.
    """
    set_default_options(prefix)
    snes = PETSc.SNES().create(comm=comm)
    snes.setOptionsPrefix(prefix)
    snes.setType(PETSc.SNES.Type.NEWTONLS)
    snes.setFunction(residual, f)
    snes.setJacobian(jacobian, J, J)
    snes.setTolerances(rtol=resi_glob_rela, atol=1e-50, max_it=iter_glob_maxi)
    test = LoadRelativeTest(load_norm, settled, scaled)
    snes.setConvergenceTest(test)
    snes.setFromOptions()
    return snes, test


# --- the options, checked before anything heavy ---------------------------------------------

class OptionError(XfcError):
    """A PETSc option is unknown or has a wrong value (exit code 2; collective: every
    process reads the same options and checks them the same way)."""

    collective = True


#: options overriding a case's iteration limits: option -> case key
ITERATION_OPTIONS = {"snes_max_it": "newton.iter_glob_maxi",
                     "contact_snes_max_it": "contact.iter_cont_maxi",
                     "friction_snes_max_it": "contact.iter_frot_maxi"}
#: tolerances: option -> (strictly positive?, the case key it overrides or "")
TOLERANCE_OPTIONS = {"snes_rtol": (True, "newton.resi_glob_rela"), "snes_atol": (False, ""),
                     "snes_stol": (False, ""), "friction_snes_rtol": (True, "contact.resi_frot"),
                     "ksp_rtol": (True, ""), "ksp_atol": (False, ""), "ksp_divtol": (True, "")}
#: the outer loops are ours: their SNES type cannot change
FIXED_OPTIONS = {"contact_snes_type": "the contact status loop", "friction_snes_type":
                 "the friction threshold loop"}
#: options of the solvers (the Newton SNES, the loops, their KSP, PC and factorisation):
#: a user option under one of these prefixes that none of them reads is refused
SOLVER_PREFIXES = ("snes_", "ksp_", "pc_", "mat_", "contact_snes_", "friction_snes_")
#: options read at the end of a solve or by viewers (not during the set-up)
_READ_LATER = re.compile(r"view|converged_reason|monitor|draw|error_if_not_converged")
#: common options, for "did you mean"
COMMON_OPTIONS = ("snes_monitor", "snes_converged_reason", "snes_rtol", "snes_atol", "snes_max_it",
                  "snes_view", "snes_linesearch_type", "contact_snes_monitor", "contact_snes_max_it",
                  "friction_snes_monitor", "friction_snes_max_it", "friction_snes_rtol", "ksp_type",
                  "ksp_view", "ksp_monitor", "pc_type", "pc_factor_mat_solver_type", "mat_type",
                  "mat_mumps_icntl_7", "mat_mumps_icntl_14", "mat_mumps_icntl_24")
LINE_SEARCHES = ("basic", "bt", "l2", "cp", "nleqerr", "shell")
#: nonlinear solvers that work on our residual and Jacobian alone (the others need a
#: DM or sub-solvers, and some crash without them)
SNES_TYPES = ("newtonls", "newtontr", "ksponly", "qn", "ngmres", "anderson", "nrichardson", "ncg",
              "vinewtonrsls", "vinewtonssls")


def user_options(argv: Sequence[str] | None = None) -> list[str]:
    """Names (without the dash) of the options the user gave on the command line."""
    import xfemcontact

    argv = xfemcontact.PETSC_ARGV if argv is None else argv
    known = PETSc.Options().getAll()
    return [tok[1:] for tok in argv if tok.startswith("-") and tok[1:] in known]


def check_options(argv: Sequence[str] | None = None) -> None:
    """Check the PETSc options before the mesh is built: integer ranges, the iteration
    limits and tolerances we document, types and MUMPS controls (on a tiny dummy
    system factorised with the options given), and options that no solver reads.
    Raises :class:`OptionError` naming the option and what it accepts."""
    set_default_options()
    opts = PETSc.Options()
    given = opts.getAll()
    names = user_options(argv)
    for name in names:
        _check_value(name, given[name])
    matrix_format()                         # -mat_type
    failure = _dummy_failure()
    if failure is not None:
        name = _culprit(names) or (names[0] if names else "")
        value = given.get(name)
        shown = f"-{name}" + (f" {value}" if value is not None else "")
        raise OptionError(f"{_clean(shown)}: {failure}{_accepted(name)}")
    for name in names:
        if name.startswith(SOLVER_PREFIXES) and not _READ_LATER.search(name) and not _used(name):
            close = difflib.get_close_matches(name, COMMON_OPTIONS, n=1, cutoff=0.6)
            hint = f" (did you mean -{close[0]}?)" if close else ""
            raise OptionError(f"-{_clean(name)}: unknown option: no solver reads it{hint}")


def _check_value(name: str, value: str | None) -> None:
    """Ranges of the options we document, and integers PETSc would wrap around."""
    from xfemcontact.case.schema import MAX_ITERATIONS

    shown = _clean(f"-{name} {value if value is not None else ''}".strip())
    if name in FIXED_OPTIONS:
        raise OptionError(f"{shown}: {FIXED_OPTIONS[name]} is a loop of xfemcontact; its type "
                          f"cannot be changed (its monitor and limits can)")
    if name == "snes_type" and (value or "").strip().lower() not in SNES_TYPES:
        raise OptionError(f"{shown}: not a nonlinear solver xfemcontact can drive (accepted: "
                          f"{', '.join(SNES_TYPES)})")
    if name in ITERATION_OPTIONS:
        if value is None or not re.fullmatch(r"\s*[+]?\d+\s*", value) or \
                not 1 <= int(value) <= MAX_ITERATIONS:
            raise OptionError(f"{shown}: expected an integer from 1 to {MAX_ITERATIONS} "
                              f"(it overrides {ITERATION_OPTIONS[name]})")
        return
    if name in TOLERANCE_OPTIONS:
        positive, key = TOLERANCE_OPTIONS[name]
        try:
            number = float(value) if value is not None else float("nan")
        except ValueError:
            number = float("nan")
        if not np.isfinite(number) or number < 0 or (positive and number == 0):
            what = "a number > 0" if positive else "a number >= 0"
            over = f" (it overrides {key})" if key else ""
            raise OptionError(f"{shown}: expected {what}{over}")
        return
    if value is not None and re.fullmatch(r"\s*[-+]?\d+\s*", value):
        limit = np.iinfo(PETSc.IntType)
        if not limit.min <= int(value) <= limit.max:
            raise OptionError(f"{shown}: integer out of range (PETSc integers here are from "
                              f"{limit.min} to {limit.max})")


#: PETSc classes whose events the dummy set-up keeps out of -log_view
_LOGGED_CLASSES = ("Matrix", "Vector", "Krylov Solver", "Preconditioner", "SNES", "SNESLineSearch",
                   "Index Set")


def _dummy_failure() -> str | None:
    """What PETSc says when it sets up our solvers with the options on a small system
    (one process), or None when it accepts them.  Not logged (``-log_view`` counts the
    run's own factorisations only)."""
    classes = [PETSc.Log.Class(name) for name in _LOGGED_CLASSES]
    for c in classes:
        c.deactivate()
    try:
        return _dummy_set_up()
    finally:
        for c in classes:
            c.activate()


def _dummy_set_up() -> str | None:
    objects: list[Any] = []
    try:
        A = _dummy_matrix()
        objects.append(A)
        snes = PETSc.SNES().create(comm=PETSc.COMM_SELF)
        objects.append(snes)
        snes.setType(PETSc.SNES.Type.NEWTONLS)
        snes.setFromOptions()
        ksp = snes.getKSP()
        ksp.setOperators(A, A)
        ksp.setUp()                         # the factorisation reads the MUMPS controls
        for prefix in ("contact_", "friction_"):
            loop = PETSc.SNES().create(comm=PETSc.COMM_SELF)
            objects.append(loop)
            loop.setOptionsPrefix(prefix)
            loop.setType(PETSc.SNES.Type.PYTHON)
            loop.setPythonContext(_NoLoop())
            loop.setFromOptions()
    except PETSc.Error as exc:
        return _petsc_message(exc)
    finally:
        for obj in objects:
            try:
                obj.destroy()
            except PETSc.Error:         # half set up by a refused option
                pass
    return None


class _NoLoop:
    def solve(self, snes: PETSc.SNES, b: PETSc.Vec | None,
              x: PETSc.Vec) -> None:       # pragma: no cover - never solved
        pass


#: size of the system the options are tried on: MUMPS's PORD ordering (``-mat_mumps_icntl_7
#: 4``) cannot order a graph of 2 vertices ("no valid number of stages in multisector") and
#: ends the process (exit status 255, before this was 4 every run given that option died)
DUMMY_SIZE = 4


def _dummy_matrix() -> PETSc.Mat:
    """A small symmetric positive definite tridiagonal matrix (:data:`DUMMY_SIZE`)."""
    symmetric = matrix_format() == "sbaij"
    n = DUMMY_SIZE
    A = (PETSc.Mat().createSBAIJ(n, 1, nnz=2, comm=PETSc.COMM_SELF) if symmetric else
         PETSc.Mat().createAIJ(n, nnz=3, comm=PETSc.COMM_SELF))
    for i in range(n):
        A.setValue(i, i, 4.0)
        if i + 1 < n:
            A.setValue(i, i + 1, -1.0)
            if not symmetric:
                A.setValue(i + 1, i, -1.0)
    A.assemble()
    return A


def _culprit(names: Sequence[str]) -> str | None:
    """The user option without which the dummy set-up succeeds (None if none alone)."""
    opts = PETSc.Options()
    for name in names:
        value = opts.getString(name, None) if opts.hasName(name) else None
        opts.delValue(name)
        try:
            if _dummy_failure() is None:
                return name
        finally:
            opts.setValue(name, value if value is not None else "")
    return None


def _petsc_message(exc: Exception) -> str:
    """The last line of a PETSc error (without the ``[0]`` prefix), on one line."""
    lines = [line.split("]", 1)[-1].strip() for line in str(exc).splitlines() if line.strip()]
    lines = [line for line in lines if line and not line.startswith(("error code", "See https"))
             and not re.search(r"\(\) at ", line)]
    text = lines[-1] if lines else str(exc).strip()
    return _clean(text)


def _accepted(name: str) -> str:
    """`` (accepted here: ...)`` for the type options, "" for others."""
    values: list[str] = []
    if name.endswith("pc_type"):
        values = _types(PETSc.PC, PETSc.PC.Type)
    elif name.endswith("ksp_type"):
        values = _types(PETSc.KSP, PETSc.KSP.Type)
    elif name.endswith("snes_linesearch_type"):
        values = list(LINE_SEARCHES)
    elif name.endswith("snes_type"):        # some SNES types cannot even be created bare
        values = list(SNES_TYPES)
    elif name.endswith("pc_factor_mat_solver_type"):
        return _solvers()
    return f" (accepted here: {', '.join(values)})" if values else ""


def _types(cls: Any, enum: Any) -> list[str]:
    """The names of ``enum`` (a PETSc type enumeration) that ``cls`` (KSP, PC) can be set to."""
    out = []
    for attr in sorted(vars(enum)):
        value = getattr(enum, attr)
        if attr.startswith("_") or not isinstance(value, str):
            continue
        obj = cls().create(comm=PETSc.COMM_SELF)
        try:
            obj.setType(value)
            out.append(value)
        except PETSc.Error:
            pass
        finally:
            try:
                obj.destroy()
            except PETSc.Error:
                pass
    return sorted(set(out))


def _solvers() -> str:
    """`` (available here: with -pc_type cholesky: ...; with -pc_type lu: ...)``."""
    opts = PETSc.Options()
    saved = {k: opts.getString(k, None) if opts.hasName(k) else None
             for k in ("pc_type", "pc_factor_mat_solver_type", "mat_type")}
    found: dict[str, list[str]] = {}
    try:
        for pc in ("cholesky", "lu"):
            for solver in sorted({v for k, v in vars(PETSc.Mat.SolverType).items()
                                  if not k.startswith("_") and isinstance(v, str)}):
                opts.setValue("pc_type", pc)
                opts.setValue("pc_factor_mat_solver_type", solver)
                opts.delValue("mat_type")
                if _dummy_failure() is None:
                    found.setdefault(pc, []).append(solver)
    finally:
        for k, v in saved.items():
            opts.delValue(k)
            if v is not None:
                opts.setValue(k, v)
    parts = [f"with -pc_type {pc}: {', '.join(s)}" for pc, s in found.items()]
    return f" (available here: {'; '.join(parts)})" if parts else ""


def _used(name: str) -> bool:
    """Whether PETSc read option ``name`` (PetscOptionsUsed)."""
    import ctypes

    fn = ctypes.CDLL(PETSc.__file__).PetscOptionsUsed
    fn.restype = ctypes.c_int
    fn.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.POINTER(ctypes.c_int)]
    flag = ctypes.c_int(0)
    if fn(None, name.encode(), ctypes.byref(flag)) != 0:
        return True                          # cannot tell: do not refuse
    return bool(flag.value)


def _clean(text: object) -> str:
    text = " ".join(str(text).split())
    text = "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)
    return text if len(text) <= 200 else text[:197] + "..."
