"""Why a run did not converge: which loop, the last residuals, what to do.

:func:`diagnose` reads the model's :class:`~xfemcontact.solver.nonlinear.NonlinearSolver`
and interface problem after a solve whose outermost reason is not positive, and
returns the facts written to results.json (``"diagnostics"``) and the one-line
message of the error.
"""
from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import numpy as np

from xfemcontact._petsc import PETSc

if TYPE_CHECKING:
    from xfemcontact.model import Model


def _names(reasons: Any) -> dict[int, str]:
    """value -> name of a PETSc reason enumeration (the first name of aliases)."""
    out: dict[int, str] = {}
    for name, value in vars(reasons).items():
        if isinstance(value, int) and not name.startswith("_"):
            out.setdefault(value, name)
    return out


_SNES = _names(PETSc.SNES.ConvergedReason)
_KSP = _names(PETSc.KSP.ConvergedReason)
#: MUMPS INFOG(1) -> what to do
_MUMPS_HINTS = {
    -8: "MUMPS ran out of work space: raise -mat_mumps_icntl_14 (e.g. 50)",
    -9: "MUMPS ran out of work space: raise -mat_mumps_icntl_14 (e.g. 50)",
    -10: "MUMPS found the matrix numerically singular: check the supports and the interface law",
    -13: "MUMPS could not allocate memory: use more processes or a machine with more memory",
    -19: "MUMPS hit the memory limit -mat_mumps_icntl_23: raise it",
    -38: "the parallel analysis (-mat_mumps_icntl_28 2) needs PT-Scotch or ParMETIS inside MUMPS, "
         "which the MUMPS linked here lacks (Debian's libmumps-ptscotch has PT-Scotch): leave "
         "-mat_mumps_icntl_28 at 1 (sequential analysis, the default)",
}


def coef_frot_hint(model: Model) -> str:
    """A sentence suggesting COEF_FROT of the order of E / (h mu |LAGS_C|) when the one
    given is far below it (semi-multiplier form), else "" (collective).

    The trial value LAGS_F1 - COEF_FROT [u].tau compares a dimensionless multiplier
    with a slip: with a slip stiffness E / h and a threshold mu |s|, a slip of one
    threshold's worth moves the trial by COEF_FROT h mu |s| / E, which must not be
    tiny for Newton to tell stick from slip.
    """
    from mpi4py import MPI

    problem, mesh = model.problem, model.mesh
    law = problem.law if problem is not None else None
    # only the Gauss-point form has a trial value
    if problem is None or law is None or not problem.fallbacks or law.unknown == "traction":
        return ""
    mpi = model.comm.tompi4py()
    xv = mesh.x[mesh.cell_nodes[:, :mesh.element.nv]]
    edges = np.linalg.norm(xv - np.roll(xv, 1, axis=1), axis=2).max(axis=1)
    h = mpi.allreduce(float(edges.sum()), op=MPI.SUM) / max(mpi.allreduce(len(edges), op=MPI.SUM), 1)
    s = problem.largest_threshold()
    if h <= 0 or s <= 0:
        return ""
    scale = model.case.material.E / (h * law.mu * s)
    if law.coef_frot >= 0.01 * scale:
        return ""
    return (f"COEF_FROT = {law.coef_frot:g} is small for this problem (E / (h mu |LAGS_C|) = "
            f"{scale:.2g}): try coef_frot of that order, Newton then tells stick from slip")


def diagnose(model: Model, reason: int, outdir: str | os.PathLike[str]) -> dict[str, Any]:
    """What did not converge and why (collective: every process gets the same dict).

    Keys: ``loop`` ("newton", "linear solver", "contact" or "friction"),
    ``reason`` / ``reason_name`` (outermost SNES), ``newton_reason``,
    ``last_residuals`` (last residual norms of the last Newton solve, absolute)
    and ``relative_residuals`` (divided by the load norm), ``load_norm``,
    ``status_changes`` (points whose contact status changed at the last status
    iteration, None without contact), ``threshold_change`` (last relative
    change of the friction thresholds), ``linear_solver`` (KSP reason, MUMPS
    INFOG(1)) and ``message`` (one line, the error printed).
    """
    case, solver = model.case, model.solver
    assert solver is not None                       # after a solve
    snes, loops = solver.newton, solver.record
    # with loops (a record): the interface problem and the loops' SNES (petsc4py), else None
    problem: Any = model.problem
    outer: Any = solver.outer
    contact: Any = solver.contact
    R = PETSc.SNES.ConvergedReason
    newton_reason = int(snes.getConvergedReason())
    history = [float(r) for r in solver.newton_test.history]
    last_solve = loops.newton[-1] + 1 if loops is not None and loops.newton else len(history)
    last = history[-min(max(last_solve, 1), 3):] if history else []
    load = float(model.load_norm or 0.0)
    relative = [r / load for r in last] if load > 0 else []
    ksp_reason = int(snes.getKSP().getConvergedReason())
    mumps = None
    try:
        info = solver.info() or {}
        mumps = (info.get("mumps") or {}).get("status")
    except Exception:       # no factorisation: nothing to say about it
        pass
    if newton_reason == R.DIVERGED_LINEAR_SOLVE and solver.linear_failure is not None:
        ksp_reason = solver.linear_failure["ksp_reason"]   # the KSP was reset since (solve_newton)
    changes = int(loops.status_changes[-1]) if loops is not None and loops.status_changes else None
    threshold = None
    if loops is not None and loops.threshold_changes:
        threshold = float(loops.threshold_changes[-1])

    loop = "newton"
    friction = loops is not None and problem.friction
    if loops is not None:
        contact_reason = int(contact.getConvergedReason())
        if friction and reason == R.DIVERGED_MAX_IT:
            loop = "friction"
        elif contact_reason == R.DIVERGED_MAX_IT:
            loop = "contact"
    if loop == "newton" and newton_reason == R.DIVERGED_LINEAR_SOLVE:
        loop = "linear solver"

    c = case.contact
    if loop == "friction":
        what = (f"friction thresholds still changing after ITER_FROT_MAXI = "
                f"{outer.getTolerances()[3]} iterations (relative change "
                f"{threshold:.3g} > RESI_FROT = {c.resi_frot:g}); raise iter_frot_maxi")
    elif loop == "contact":
        what = (f"contact statuses still changing after ITER_CONT_MAXI = "
                f"{contact.getTolerances()[3]} iterations; raise iter_cont_maxi, "
                f"or use smaller load steps")
    elif loop == "linear solver":
        what = f"the linear solver failed ({_KSP.get(ksp_reason, ksp_reason)}"
        what += f", MUMPS INFOG(1) = {mumps})" if mumps is not None else ")"
        if mumps in _MUMPS_HINTS:
            what += f": {_MUMPS_HINTS[mumps]}"
    elif newton_reason == R.DIVERGED_MAX_IT and relative and relative[-1] > 1.0:
        what = (f"Newton did not converge in ITER_GLOB_MAXI = {snes.getTolerances()[3]} "
                f"iterations and its residual ends {relative[-1]:.2g} times the loads: the tangent "
                f"is probably singular, not too few iterations; check that no part is held by the "
                f"interface alone while it opens (contact_init = NON, a part pulled away) and the "
                f"supports")
    elif newton_reason == R.DIVERGED_MAX_IT:
        what = (f"Newton did not converge in ITER_GLOB_MAXI = {snes.getTolerances()[3]} "
                f"iterations (RESI_GLOB_RELA = {snes.getTolerances()[0]:g}); raise "
                f"iter_glob_maxi")
    elif newton_reason == R.DIVERGED_FNORM_NAN:
        what = "Newton: the residual is NaN or infinite"
    else:
        what = f"Newton diverged ({_SNES.get(newton_reason, newton_reason)})"
    solve = history[-last_solve:] if history else []
    cycling = len(solve) > 5 and min(solve) < 0.1 * solve[-1]     # got low, then jumped back
    if loop == "newton" and friction and cycling:
        hint = coef_frot_hint(model)
        if hint:
            what += f"; {hint}"
    parts = [f"{case.source}: no convergence: {what}"]
    if last:
        rel = f" (relative to the loads: {relative[-1]:.3e})" if relative else ""
        parts.append("last residuals " + ", ".join(f"{r:.3e}" for r in last) + rel)
    if changes is not None:
        parts.append(f"{changes} point(s) changed contact status at the last status iteration")
    parts.append(f"see {outdir}/results.json")
    return {
        "loop": loop, "reason": int(reason), "reason_name": _SNES.get(int(reason), str(reason)),
        "newton_reason": newton_reason, "last_residuals": last, "relative_residuals": relative,
        "load_norm": load, "status_changes": changes, "threshold_change": threshold,
        "linear_solver": {"ksp_reason": _KSP.get(ksp_reason, ksp_reason), "mumps_infog1": mumps},
        "message": "; ".join(parts),
    }
