"""Run a case from start to end: solve, test table, result files.

Exit codes: 0 solved and every test OK; 1 some test NOOK; 2 bad input;
3 no convergence; 130/143 interrupted by SIGINT/SIGTERM.

Order: read the case, check the output folder (and that it can be written), the
PETSc and ``-xfc_*`` options, build the input mesh and check the case against it
(:mod:`xfemcontact.preflight`, before anything heavy), set up and solve, evaluate
the tests (only when converged), write the files into a temporary folder,
results.json last, and put it into place.
"""
from __future__ import annotations

import dataclasses
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Iterable

import numpy as np

from xfemcontact import options, preflight, timing
from xfemcontact._petsc import PETSc
from xfemcontact.case import load_case, schema
from xfemcontact.errors import ConvergenceError, GeometryError, Interrupted, XfcError
from xfemcontact.output import results
from xfemcontact.output.folder import OutputFolder
from xfemcontact.post import testtable
from xfemcontact.solver.diagnose import diagnose
from xfemcontact.solver.newton import check_options

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.case.load import Case, TestSpec
    from xfemcontact.history.checkpoint import Checkpoints
    from xfemcontact.model import Model
    from xfemcontact.post.fields import PointValues


def say(comm: PETSc.Comm, *lines: str) -> None:
    """Lines on stdout (rank 0).  A closed standard output (``| head -1``) is no reason
    to stop: what follows goes nowhere."""
    if comm.rank == 0:
        for line in lines:
            try:
                print(line, flush=True)
            except BrokenPipeError:
                _stdout_to_null()


def _stdout_to_null() -> None:
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)


def node_samples(model: Model, u: NDArray[np.float64]) -> testtable.Samples:
    """DX, DY ``u (n, 2)`` at the nodes this process owns."""
    own = model.mesh.node_owned
    x = model.mesh.x[own]
    names = model.case.components
    return testtable.Samples(x[:, 0], x[:, 1], {c: u[own, i] for i, c in enumerate(names)},
                             z=x[:, 2] if x.shape[1] == 3 else None)


def cell_samples(model: Model, values: Iterable[PointValues]) -> testtable.Samples:
    """The stress components at the quadrature points of ``values`` (those of positive
    weight); empty on a process without cells (more processes than cells)."""
    d = model.mesh.dim
    names = schema.CELL_FIELDS_3D if d == 3 else schema.CELL_FIELDS
    xs, ss = [], []
    for v in values:
        live = v.w > 0
        xs.append(v.x[live])
        ss.append(v.stress[live])
    x = np.concatenate(xs) if xs else np.zeros((0, d))
    s = np.concatenate(ss) if ss else np.zeros((0, len(names)))
    return testtable.Samples(x[:, 0], x[:, 1], {name: s[:, i] for i, name in enumerate(names)},
                             z=x[:, 2] if d == 3 else None)


def test_samples(model: Model, tests: Iterable[TestSpec]) -> dict[str, testtable.Samples]:
    """The samples the ``tests`` look at: {"node"|"cell"|"interface": Samples}, only
    the kinds they need (cell samples are the stresses at every quadrature point)."""
    kinds = {t.kind for t in tests}
    samples: dict[str, testtable.Samples] = {}
    if "node" in kinds:
        samples["node"] = node_samples(model, model.displacement())
    if "cell" in kinds:
        samples["cell"] = cell_samples(model, model.stresses())
    if "interface" in kinds and hasattr(model, "interface_samples"):
        samples.update(model.interface_samples())
    return samples


def run(case_path: str | os.PathLike[str], outdir: str | None = None, overwrite: bool = False,
        restart: bool = False, quiet: bool = False) -> int:
    """Solve ``case_path``, write results into ``outdir``; return the exit code.

    Raises :class:`ConvergenceError` (exit code 3) after writing the results of
    a run that did not converge (results.json with ``"converged": false`` and
    ``"diagnostics"``, no test table), and :class:`Interrupted` (with its
    ``outcome``) when SIGINT or SIGTERM stopped it.

    A case with ``[instants]`` is solved step by step (:mod:`xfemcontact.history`):
    one progress line per step (none with ``quiet``), checkpoints beside the
    output folder, and ``restart`` resumes after the last completed step.
    """
    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    t0 = time.perf_counter()
    timing.reset()
    timing.start_logging()
    folder: OutputFolder | None = None
    checkpoints: Checkpoints | None = None
    if PETSc.Options().hasName("help"):
        say(comm, *options.help_lines())
    try:
        case = load_case(case_path)
        outdir = outdir or f"results/{case.name}"
        if restart and not case.instants.given:
            raise XfcError(f"{case.source}: --restart: the case has no [instants] (one step): "
                           f"nothing to restart from; run it again without --restart",
                           collective=True)
        folder = OutputFolder(outdir, overwrite or restart, mpi)
        if folder.cleaned:
            warn(comm, f"{outdir}: removed what earlier interrupted runs left: "
                       f"{', '.join(folder.cleaned)}")
        if case.instants.given:
            from xfemcontact.history.checkpoint import Checkpoints

            checkpoints = Checkpoints(outdir, case, mpi, restart=restart, overwrite=overwrite)
        options.check_all()
        check_options()
    except Interrupted as exc:
        exc.outcome = _untouched(outdir)
        raise
    try:
        from xfemcontact.model import Model

        preflight.check_case(case, mpi)       # a rectangle that cannot fit: refused before it is built
        if case.output.plots and not case.instants.given:
            # where a core is spare the plot helpers start now: they import matplotlib,
            # one after the other on that core, while the run builds and solves its model
            folder.start_plot_helper()
        with timing.phase("mesh"):
            raw = preflight.build_mesh(case, mpi)
        with timing.phase("checks"):
            pre = preflight.preflight(case, raw, mpi)
            if case.instants.given:
                from xfemcontact.history.loading import check_instants

                check_instants(case, raw, mpi)
        warn(comm, *pre.warnings)
        if not pre.interface:
            case = dataclasses.replace(case, interface=None)
        try:
            model = Model.from_case(case, raw)
        except GeometryError as exc:
            raise _named(exc, case) from None
        del raw
        warn(comm, *preflight.readjustment_warnings(case, model))
        say(comm, f"{case.title}: {model.layout.global_size} dofs on {comm.size} process(es)")
        if case.instants.given:
            assert checkpoints is not None           # made for a case with [instants]
            return _run_history(case, model, folder, checkpoints, outdir, pre, comm, quiet, t0)
        tic = time.perf_counter()
        reason = model.solve()
        seconds = time.perf_counter() - tic
        model.release_factors()
        converged = reason > 0
        loop_warnings = model.run_warnings()
        warn(comm, *loop_warnings)
        diagnostics = None if converged else diagnose(model, reason, outdir)
        outcomes: list[testtable.Outcome] = []
        with timing.phase("post"):
            if converged:      # tests on a run that did not converge would mean nothing
                outcomes = testtable.evaluate(case.tests, test_samples(model, case.tests), case.reference, comm)
        try:
            with timing.phase("output"):
                results.write_outputs(folder, model, converged, reason, outcomes,
                                      warnings=pre.warnings)
            timing.TIMINGS["total"] = time.perf_counter() - t0
            summary = results.summary(model, converged, reason, outcomes)
            summary["steps"] = [{"index": 1, "inst": case.instants.last, "start": case.instants.values[0],
                                 "level": 0, "listed": True, "converged": bool(converged),
                                 "seconds": round(seconds, 4), "seconds_total": round(seconds, 4), "iterations": summary["iterations"],
                                 "interface": summary["interface"]}]
            summary["warnings"] = pre.warnings + list(summary.get("warnings") or [])
            if pre.resolution is not None:
                summary["interface_resolution"] = pre.resolution
            if diagnostics is not None:
                summary["diagnostics"] = diagnostics
                summary["tests"] = []
                summary["tests_skipped"] = f"not converged: {len(case.tests)} test(s) not evaluated"
            folder.write_json("results.json", summary)      # last: the folder is complete
            folder.commit()
        except OSError as exc:           # full disk, folder removed under us ...
            raise XfcError(f"{outdir}: cannot write the results: {_os_reason(exc)}; the "
                           f"previous results, if any, are kept") from None
    except Interrupted as exc:
        folder.abort()
        exc.outcome = folder.outcome() + _checkpointed(checkpoints, outdir)
        raise
    except BaseException:
        folder.abort()
        raise
    try:                   # the results are in place: an interruption now loses nothing
        if outcomes:
            say(comm, *testtable.table(outcomes))
        if not converged:
            say(comm, f"NOT CONVERGED: last iterate and diagnostics in {outdir}/ "
                      f"(results.json: \"converged\": false; {len(case.tests)} test(s) not "
                      f"evaluated)")
            assert diagnostics is not None           # made when not converged
            raise ConvergenceError(diagnostics["message"], diagnostics=diagnostics)
        say(comm, f"results in {outdir}/ ({timing.TIMINGS['total']:.2f} s)")
    except Interrupted as exc:
        exc.outcome = folder.outcome()
        raise
    return 0 if all(o.ok for o in outcomes) else 1


def _run_history(case: Case, model: Model, folder: OutputFolder, checkpoints: Checkpoints, outdir: str,
                 pre: preflight.Preflight, comm: PETSc.Comm, quiet: bool, t0: float) -> int:
    """The load steps of a case with ``[instants]``, its results and exit code (inside
    :func:`run`'s handling of the output folder)."""
    from xfemcontact.history.stepping import Stepper
    from xfemcontact.output import series

    checkpoints.check_layout(model)
    stepper = Stepper(model, say=None if quiet else (lambda *lines: say(comm, *lines)),
                      samples=test_samples, checkpoints=checkpoints)
    if checkpoints.manifest is not None:
        stepper.resume(checkpoints.manifest)
        n = checkpoints.manifest["completed"]
        say(comm, f"resumed after step {n} (t = {stepper.time:g}) from {checkpoints.path}")
    reason = stepper.run()             # model.solve times its phase ("solve")
    converged = stepper.failure is None
    diagnostics = None
    if not converged:
        diagnostics = diagnose(model, reason, outdir)
        f = stepper.failure
        assert f is not None                         # not converged: the step that failed
        cut = f" after {f['level']} cut(s) (subd_niveau = {case.instants.subd_niveau})" \
            if case.instants.action == "DECOUPE" else " (echec action = ARRET)"
        head = f"{case.source}: no convergence at t = {f['inst']:g} (step from t = {f['start']:g}){cut}: "
        diagnostics["message"] = head + diagnostics["message"][len(f"{case.source}: no convergence: "):]
        diagnostics["failed_step"] = f
        stepper.restore_last()
    model.release_factors()
    warn(comm, *model.run_warnings())
    outcomes = stepper.outcomes if converged else []
    try:
        with timing.phase("output"):
            summary = series.write_outputs(folder, model, stepper, checkpoints, converged, reason,
                                           outcomes, warnings=pre.warnings)
        timing.TIMINGS["total"] = time.perf_counter() - t0
        summary["timings"] = {k: round(v, 4) for k, v in timing.TIMINGS.items()}
        summary["instants"] = list(case.instants.values)
        summary["steps"] = stepper.steps
        summary["warnings"] = pre.warnings + list(summary.get("warnings") or [])
        if pre.resolution is not None:
            summary["interface_resolution"] = pre.resolution
        if diagnostics is not None:
            summary["diagnostics"] = diagnostics
            summary["tests"] = []
            summary["tests_skipped"] = f"not converged: {len(case.tests)} test(s) not evaluated"
        folder.write_json("results.json", summary)
        folder.commit()
    except OSError as exc:
        raise XfcError(f"{outdir}: cannot write the results: {_os_reason(exc)}; the "
                       f"previous results, if any, are kept") from None
    if converged:
        checkpoints.remove()
    else:
        checkpoints.release()
    if outcomes:
        say(comm, *testtable.table(outcomes))
    if not converged:
        kept = _checkpointed(checkpoints, outdir)
        say(comm, f"NOT CONVERGED: results of {len(stepper.steps)} completed step(s) and diagnostics "
                  f"in {outdir}/ (results.json: \"converged\": false; {len(case.tests)} test(s) "
                  f"not evaluated){kept}")
        assert diagnostics is not None               # made when not converged
        raise ConvergenceError(diagnostics["message"], diagnostics=diagnostics)
    say(comm, f"results in {outdir}/ ({timing.TIMINGS['total']:.2f} s)")
    return 0 if all(o.ok for o in outcomes) else 1


def _checkpointed(checkpoints: Checkpoints | None, outdir: str) -> str:
    """``; N completed step(s) checkpointed in ... (resume with --restart)`` or ""."""
    if checkpoints is None or checkpoints.comm.rank != 0:
        return ""
    import json

    try:
        manifest = json.loads((checkpoints.path / "manifest.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return ""
    return (f"; {manifest.get('completed', 0)} completed step(s) checkpointed in "
            f"{checkpoints.path} (resume with --restart)")


def warn(comm: PETSc.Comm, *lines: str) -> None:
    """Warnings: on stderr, once (rank 0), each line prefixed with ``warning:``."""
    if comm.rank == 0:
        for line in lines:
            print(f"warning: {line}", file=sys.stderr, flush=True)


def _os_reason(exc: OSError) -> str:
    """Why a file could not be written, in a few words (HDF5 hides errno in its text)."""
    import re

    code = exc.errno
    if not code:
        found = re.search(r"errno = (\d+)", str(exc))
        code = int(found.group(1)) if found else None
    reason = os.strerror(code) if code else " ".join(str(exc).split())[:120]
    name = exc.filename or (re.search(r"filename = '([^']*)'", str(exc)) or [None, None])[1]
    return f"{reason} ({Path(name).name})" if name else reason


def _named(exc: GeometryError, case: Case) -> GeometryError:
    """A GeometryError of the cut ("level set: ...") naming the case file and its key."""
    itf = case.interface
    key = "interface.level_set" if itf is None or itf.level_set is not None else \
        "interface.level_set_field"
    text = str(exc)
    text = text[len("level set: "):] if text.startswith("level set: ") else text
    return type(exc)(f"{case.source}: {key}: {text}", collective=exc.collective)


def _untouched(outdir: str | None) -> str:
    if outdir and Path(outdir).is_dir():
        return f"previous results in {outdir} kept"
    return "no results written"
