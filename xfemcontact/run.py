"""Run a case from start to end: solve, test table, result files.

Exit codes: 0 solved and every test OK; 1 some test NOOK; 2 bad input;
3 no convergence.
"""
import time

import numpy as np

from xfemcontact import timing
from xfemcontact._petsc import PETSc
from xfemcontact.case import load_case
from xfemcontact.errors import ConvergenceError
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


def run(case_path, outdir=None, overwrite=False):
    """Solve ``case_path``, write results into ``outdir``; return the exit code."""
    comm = PETSc.COMM_WORLD
    t0 = time.perf_counter()
    timing.reset()
    case = load_case(case_path)
    outdir = outdir or f"results/{case.name}"
    folder = OutputFolder(outdir, overwrite, comm.tompi4py())
    try:
        from xfemcontact.model import Model

        model = Model.from_case(case)
        say(comm, f"{case.title}: {model.layout.global_size} dofs on {comm.size} process(es)")
        reason = model.solve()
        converged = reason > 0
        with timing.phase("post"):
            u = model.displacement()
            values = model.stresses()
            samples = {"node": node_samples(model, u), "cell": cell_samples(model, values)}
            samples.update(model.interface_samples() if hasattr(model, "interface_samples") else {})
            outcomes = checks.evaluate(case.tests, samples, case.reference, comm)
        with timing.phase("output"):
            results.write_outputs(folder, model, u, values, converged, reason, outcomes)
        timing.TIMINGS["total"] = time.perf_counter() - t0
        folder.write_json("results.json", results.summary(model, converged, reason, outcomes))
        folder.commit()
    except BaseException:
        folder.abort()
        raise
    if outcomes:
        say(comm, *checks.table(outcomes))
    say(comm, f"results in {outdir}/ ({timing.TIMINGS['total']:.2f} s)")
    if not converged:
        raise ConvergenceError(f"{case.source}: Newton did not converge (SNES reason {reason}); "
                               f"see {outdir}/results.json")
    return 0 if all(o.ok for o in outcomes) else 1
