"""Run a case from start to end: solve, test table, result files.

Exit codes: 0 solved and every test OK; 1 some test NOOK; 2 bad input;
3 no convergence; 130/143 interrupted by SIGINT/SIGTERM.

Order: read the case, check the output folder, build the input mesh and check
the case against it (:mod:`xfemcontact.checks`, before anything heavy), set up
and solve, evaluate the tests (only when converged), write the files into a
temporary folder, results.json last, and rename it into place.
"""
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from xfemcontact import checks as input_checks
from xfemcontact import timing
from xfemcontact._petsc import PETSc
from xfemcontact.case import load_case
from xfemcontact.errors import ConvergenceError, Interrupted
from xfemcontact.output import results
from xfemcontact.output.folder import OutputFolder
from xfemcontact.post import checks


def say(comm, *lines):
    if comm.rank == 0:
        for line in lines:
            print(line, flush=True)


def node_samples(model, u):
    own = model.mesh.node_owned
    x = model.mesh.x[own]
    return checks.Samples(x[:, 0], x[:, 1], {"DX": u[own, 0], "DY": u[own, 1]})


def cell_samples(model, values):
    xs, ys, s = [], [], []
    for v in values:
        live = v.w > 0
        xs.append(v.x[..., 0][live])
        ys.append(v.x[..., 1][live])
        s.append(v.stress[live])
    s = np.concatenate(s) if s else np.zeros((0, 3))
    return checks.Samples(np.concatenate(xs), np.concatenate(ys),
                          {"SIXX": s[:, 0], "SIYY": s[:, 1], "SIXY": s[:, 2]})


def test_samples(model, tests):
    """The samples the ``tests`` look at: {"node"|"cell"|"interface": Samples}, only
    the kinds they need (cell samples are the stresses at every quadrature point)."""
    kinds = {t.kind for t in tests}
    samples = {}
    if "node" in kinds:
        samples["node"] = node_samples(model, model.displacement())
    if "cell" in kinds:
        samples["cell"] = cell_samples(model, model.stresses())
    if "interface" in kinds and hasattr(model, "interface_samples"):
        samples.update(model.interface_samples())
    return samples


def run(case_path, outdir=None, overwrite=False):
    """Solve ``case_path``, write results into ``outdir``; return the exit code.

    Raises :class:`ConvergenceError` (exit code 3) after writing the results of
    a run that did not converge (results.json with ``"converged": false`` and
    ``"diagnostics"``, no test table), and :class:`Interrupted` (with its
    ``outcome``) when SIGINT or SIGTERM stopped it.
    """
    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    t0 = time.perf_counter()
    timing.reset()
    timing.start_logging()
    folder = None
    try:
        case = load_case(case_path)
        outdir = outdir or f"results/{case.name}"
        folder = OutputFolder(outdir, overwrite, mpi)
    except Interrupted as exc:
        exc.outcome = _untouched(outdir)
        raise
    try:
        from xfemcontact.model import Model

        with timing.phase("mesh"):
            raw = input_checks.build_mesh(case, mpi)
        with timing.phase("checks"):
            pre = input_checks.preflight(case, raw, mpi)
        warn(comm, *pre.warnings)
        if not pre.interface:
            case = dataclasses.replace(case, interface=None)
        model = Model.from_case(case, raw)
        del raw
        say(comm, f"{case.title}: {model.layout.global_size} dofs on {comm.size} process(es)")
        reason = model.solve()
        model.release_factors()
        converged = reason > 0
        loop_warnings = model.run_warnings()
        warn(comm, *loop_warnings)
        diagnostics = None if converged else diagnose(model, reason, outdir)
        outcomes = []
        with timing.phase("post"):
            if converged:      # tests on a run that did not converge would mean nothing
                outcomes = checks.evaluate(case.tests, test_samples(model, case.tests), case.reference, comm)
        with timing.phase("output"):
            results.write_outputs(folder, model, converged, reason, outcomes, warnings=pre.warnings)
        timing.TIMINGS["total"] = time.perf_counter() - t0
        summary = results.summary(model, converged, reason, outcomes)
        summary["warnings"] = pre.warnings + list(summary.get("warnings") or [])
        if diagnostics is not None:
            summary["diagnostics"] = diagnostics
            summary["tests"] = []
            summary["tests_skipped"] = f"not converged: {len(case.tests)} test(s) not evaluated"
        folder.write_json("results.json", summary)      # last: the folder is complete
        folder.commit()
    except Interrupted as exc:
        folder.abort()
        exc.outcome = folder.outcome()
        raise
    except BaseException:
        folder.abort()
        raise
    try:                   # the results are in place: an interruption now loses nothing
        if outcomes:
            say(comm, *checks.table(outcomes))
        if not converged:
            say(comm, f"NOT CONVERGED: last iterate and diagnostics in {outdir}/ "
                      f"(results.json: \"converged\": false; {len(case.tests)} test(s) not "
                      f"evaluated)")
            raise ConvergenceError(diagnostics["message"], diagnostics=diagnostics)
        say(comm, f"results in {outdir}/ ({timing.TIMINGS['total']:.2f} s)")
    except Interrupted as exc:
        exc.outcome = folder.outcome()
        raise
    return 0 if all(o.ok for o in outcomes) else 1


def warn(comm, *lines):
    """Warnings: on stderr, once (rank 0), each line prefixed with ``warning:``."""
    if comm.rank == 0:
        for line in lines:
            print(f"warning: {line}", file=sys.stderr, flush=True)


def _untouched(outdir):
    if outdir and Path(outdir).is_dir():
        return f"previous results in {outdir} kept"
    return "no results written"


# --- diagnostics of a run that did not converge -------------------------------------------

def _names(reasons):
    """value -> name of a PETSc reason enumeration (the first name of aliases)."""
    out = {}
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
}


def coef_frot_hint(model):
    """A sentence suggesting COEF_FROT of the order of E / (h mu |LAGS_C|) when the one
    given is far below it (semi-multiplier form), else "" (collective).

    The trial value LAGS_F1 - COEF_FROT [u].tau compares a dimensionless multiplier
    with a slip: with a slip stiffness E / h and a threshold mu |s|, a slip of one
    threshold's worth moves the trial by COEF_FROT h mu |s| / E, which must not be
    tiny for Newton to tell stick from slip.
    """
    from mpi4py import MPI

    law, op, mesh = model.law, model.interface, model.mesh
    if law.unknown == "traction" or op is None:
        return ""
    mpi = model.comm.tompi4py()
    xv = mesh.x[mesh.cell_nodes[:, :mesh.element.nv]]
    edges = np.linalg.norm(xv - np.roll(xv, 1, axis=1), axis=2).max(axis=1)
    h = mpi.allreduce(float(edges.sum()), op=MPI.SUM) / max(mpi.allreduce(len(edges), op=MPI.SUM), 1)
    s = mpi.allreduce(float(np.abs(op.s).max(initial=0.0)), op=MPI.MAX)
    if h <= 0 or s <= 0:
        return ""
    scale = model.case.material.E / (h * law.mu * s)
    if law.coef_frot >= 0.01 * scale:
        return ""
    return (f"COEF_FROT = {law.coef_frot:g} is small for this problem (E / (h mu |LAGS_C|) = "
            f"{scale:.2g}): try coef_frot of that order, Newton then tells stick from slip")


def diagnose(model, reason, outdir):
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
    case, snes, loops = model.case, model.snes, model.loops
    R = PETSc.SNES.ConvergedReason
    newton_reason = int(snes.getConvergedReason())
    history = [float(r) for r in getattr(model.newton_test, "history", [])]
    last_solve = loops.newton[-1] + 1 if loops is not None and loops.newton else len(history)
    last = history[-min(max(last_solve, 1), 3):] if history else []
    load = float(getattr(model, "load_norm", 0.0) or 0.0)
    relative = [r / load for r in last] if load > 0 else []
    ksp_reason = int(snes.getKSP().getConvergedReason())
    mumps = None
    try:
        info = model.solver_info() or {}
        mumps = (info.get("mumps") or {}).get("status")
    except Exception:       # no factorisation: nothing to say about it
        pass
    if newton_reason == R.DIVERGED_LINEAR_SOLVE and model.linear_failure is not None:
        ksp_reason = model.linear_failure["ksp_reason"]   # the KSP was reset since (solve_newton)
    changes = int(loops.status_changes[-1]) if loops is not None and loops.status_changes else None
    threshold = None
    if loops is not None and loops.threshold_changes:
        threshold = float(loops.threshold_changes[-1])

    loop = "newton"
    if loops is not None:
        friction = model.law.friction
        contact_reason = int(model.contact_snes.getConvergedReason())
        if friction and reason == R.DIVERGED_MAX_IT:
            loop = "friction"
        elif contact_reason == R.DIVERGED_MAX_IT:
            loop = "contact"
    if loop == "newton" and newton_reason == R.DIVERGED_LINEAR_SOLVE:
        loop = "linear solver"

    c = case.contact
    if loop == "friction":
        what = (f"friction thresholds still changing after ITER_FROT_MAXI = "
                f"{model.outer_snes.getTolerances()[3]} iterations (relative change "
                f"{threshold:.3g} > RESI_FROT = {c.resi_frot:g}); raise iter_frot_maxi")
    elif loop == "contact":
        what = (f"contact statuses still changing after ITER_CONT_MAXI = "
                f"{model.contact_snes.getTolerances()[3]} iterations; raise iter_cont_maxi, "
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
    if loop == "newton" and loops is not None and model.law.friction and cycling:
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
