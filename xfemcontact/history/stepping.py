"""Load steps: from one instant of ``[instants]`` to the next, STAT_NON_LINE's way.

Each step applies the loads of its instant (:class:`~xfemcontact.history.loading.Loading`)
and solves from the converged state of the previous one: the solution
(multipliers included), the contact and friction statuses, the thresholds (the
contact pressures of that solution) carry over, and friction counts the slip
of the step (:meth:`begin_step` of the interface problem).  CONTACT_INIT and
SEUIL_INIT act in the first step only.

A step that does not converge (ECHEC, EVENEMENT = 'ERREUR') is, with ACTION =
'DECOUPE', SUBD_METHODE = 'MANUEL', restarted from the state of its start as
``subd_pas`` equal steps; a piece that fails again is cut again, up to
``subd_niveau`` nested levels; then (or with ACTION = 'ARRET') the run stops:
exit code 3, with every completed step's results.  The instants created by the
cutting are steps like the others (``"level"`` > 0 in their record).

After each completed step: its record (instant, iterations, status changes,
seconds, the interface table, the tests at that instant), one progress line on
standard output, and a checkpoint (:mod:`xfemcontact.history.checkpoint`).
"""
from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Callable, Iterable

import numpy as np

from xfemcontact.history.loading import Loading
from xfemcontact.post import testtable

if TYPE_CHECKING:
    from numpy.typing import NDArray
    from petsc4py import PETSc

    from xfemcontact.case.load import TestSpec
    from xfemcontact.history.checkpoint import Checkpoints
    from xfemcontact.model import Model

    #: the samples of the tests: :func:`xfemcontact.run.test_samples`
    SampleFunction = Callable[[Model, Iterable[TestSpec]], dict[str, testtable.Samples]]


class Stepper:
    """The load steps of ``model.case`` (see the module documentation).

    ``say(*lines)``: progress output (rank 0, None: quiet); ``samples(model, tests)``:
    the samples of the tests (:func:`xfemcontact.run.test_samples`);
    ``checkpoints``: a :class:`~xfemcontact.history.checkpoint.Checkpoints` or None.
    """

    _failed_start: tuple[PETSc.Vec, dict[str, Any]]     # after a failure: the start of the failed step

    def __init__(self, model: Model, say: Callable[..., None] | None = None,
                 samples: SampleFunction | None = None, checkpoints: Checkpoints | None = None) -> None:
        self.model, self.case = model, model.case
        self.say = say
        self.samples = samples
        self.checkpoints = checkpoints
        self.loads = Loading(model)
        model.keep_bulk_values()
        self.comm = model.comm
        self.instants = self.case.instants
        self.steps: list[dict[str, Any]] = []    # records (rank 0 holds the interface tables)
        self.outcomes: list[testtable.Outcome] = []     # tests of every completed step
        self.time = self.instants.values[0]
        #: (instant, cut level, listed in [instants]) of every step to do
        self.pending: list[tuple[float, int, bool]] = [(t, 0, True) for t in self.instants.values[1:]]
        #: instant, level, reason and start of the step that stopped the run
        self.failure: dict[str, Any] | None = None

    # -- restart -------------------------------------------------------------------
    def resume(self, manifest: dict[str, Any]) -> None:
        """Continue after the last completed step of ``manifest`` (collective)."""
        cp = self.checkpoints
        assert cp is not None                    # a manifest comes from the checkpoints
        records = cp.records()
        light = [{k: v for k, v in r.items() if k != "interface"} for r in records]
        light = self.comm.tompi4py().bcast(light, root=0)
        self.steps = records if self.comm.rank == 0 else light
        self.time = manifest["time"]
        self.pending = [(t, level, listed) for t, level, listed in manifest["pending"]]
        self.loads.reference = manifest["load_reference"]
        cp.load(self.model, manifest["completed"])
        self.loads.apply(self.time)
        for record in self.steps:
            self.outcomes += [_outcome(d) for d in record["tests"]]

    # -- the steps -----------------------------------------------------------------
    def run(self) -> int:
        """Solve every pending step; the reason of the last solve (> 0: all converged)."""
        model = self.model
        reason = 1
        total = len(self.instants.values) - 1
        while self.pending:
            target, level, listed = self.pending[0]
            start_x = model.x.copy()
            start_state = model.problem.state() if model.problem is not None else {}
            first = not self.steps
            counts0 = self._counts()
            tic = time.perf_counter()
            self.loads.apply(target)
            if model.problem is not None:
                model.problem.begin_step(model.x, first)
            reason = model.solve()
            seconds = time.perf_counter() - tic
            where = self._where(target, level, total)
            if reason > 0:
                self.pending.pop(0)
                self._complete(target, level, listed, counts0, start_state, seconds, where, tic)
                continue
            if self.instants.action == "DECOUPE" and level < self.instants.subd_niveau:
                start_x.copy(model.x)
                if model.problem is not None:
                    model.problem.set_state(start_state)
                pas = self.instants.subd_pas
                t0 = self.time
                pieces = [(t0 + (target - t0) * j / pas, level + 1, False) for j in range(1, pas)]
                self.pending[0:1] = pieces + [(target, level + 1, listed)]
                self._say(f"{where}: no convergence ({seconds:.2f} s): cut into {pas} steps "
                          f"(level {level + 1} of {self.instants.subd_niveau})")
                continue
            self.failure = {"inst": target, "level": level, "reason": int(reason),
                            "start": self.time}
            self._say(f"{where}: no convergence ({seconds:.2f} s)" +
                      ("" if self.instants.action == "ARRET" or not self.instants.given else
                       f": cut {level} time(s) already, subd_niveau = {self.instants.subd_niveau}"))
            self._failed_start = (start_x, start_state)
            return reason
        return reason

    def restore_last(self) -> None:
        """After a failure: the model back at its last completed step (its loads too)."""
        start_x, start_state = self._failed_start
        start_x.copy(self.model.x)
        if self.model.problem is not None:
            self.model.problem.set_state(start_state)
        self.loads.apply(self.time)

    def _where(self, target: float, level: int, total: int) -> str:
        listed = [i for i, t in enumerate(self.instants.values) if t >= target]
        index = listed[0] if listed else total
        cut = f", cut level {level}" if level else ""
        return f"t = {target:.6g} (step {index}/{total}{cut})"

    def _say(self, line: str) -> None:
        if self.say is not None:
            self.say(line)

    def _counts(self) -> dict[str, int]:
        solver = self.model.solver
        if solver is None:
            return {"newton": 0, "solves": 0, "contact": 0, "jacobians": 0, "history": 0}
        rec = solver.record
        return {"newton": sum(rec.newton) if rec else solver.newton.getIterationNumber(),
                "solves": len(rec.newton) if rec else 0, "contact": len(rec.contact) if rec else 0,
                "jacobians": solver.jacobians, "history": len(solver.newton_test.history)}

    def _iterations(self, c0: dict[str, int]) -> dict[str, Any]:
        solver = self.model.solver
        assert solver is not None                # after a solve
        rec = solver.record
        if rec is None:
            n = solver.newton.getIterationNumber()
            return {"newton": n, "jacobians": solver.jacobians - c0["jacobians"]}
        return {"newton": int(sum(rec.newton[c0["solves"]:])),
                "newton_per_solve": [int(n) for n in rec.newton[c0["solves"]:]],
                "contact": [int(n) for n in rec.contact[c0["contact"]:]],
                "friction": int(rec.friction) if rec.friction else 0,
                "jacobians": solver.jacobians - c0["jacobians"]}

    def _complete(self, target: float, level: int, listed: bool, c0: dict[str, int],
                  start_state: dict[str, Any], seconds: float, where: str, tic: float) -> None:
        """Record, test, report and checkpoint a converged step (``seconds``: the solve,
        ``tic``: when the step started)."""
        from xfemcontact.output.results import interface_table

        model, case = self.model, self.case
        iterations = self._iterations(c0)
        changes = model.problem.status_changes(start_state) if model.problem is not None else 0
        tests = [t for t in case.tests if listed and t.inst == target]
        outcomes: list[testtable.Outcome] = []
        if tests:
            assert self.samples is not None, "a case with tests needs the samples function"
            outcomes = testtable.evaluate(tests, self.samples(model, tests), case.reference_at(target),
                                          self.comm)
            for o in outcomes:
                o.inst = target
        table = interface_table(model)
        path = self.loads.path(target)
        record: dict[str, Any] = {"index": len(self.steps) + 1, "inst": float(target), "start": float(self.time),
                  "level": int(level), "listed": bool(listed), "converged": True,
                  "seconds": round(seconds, 4), "iterations": iterations,
                  "status_changes": int(changes), "load_norm": float(model.load_norm),
                  "loads": path, "tests": [o.as_dict() for o in outcomes]}
        if table is not None:
            previous = self.steps[-1]["interface"] if self.steps and "interface" in self.steps[-1] else None
            table["slip_path"] = slip_path(table, previous).tolist()
            record["interface"] = table
        self.steps.append(record if self.comm.rank == 0 else {k: v for k, v in record.items()
                                                              if k != "interface"})
        self.outcomes += outcomes
        self.time = target
        n_newton = iterations["newton"]
        self._say(f"{where}: {n_newton} Newton iteration{'s' if n_newton != 1 else ''}, "
                  f"{changes} status change{'s' if changes != 1 else ''}, {seconds:.2f} s")
        record["seconds_total"] = round(time.perf_counter() - tic, 4)
        if self.checkpoints is not None:
            plan = {"time": float(self.time), "pending": [list(p) for p in self.pending],
                    "load_reference": self.loads.reference}
            self.checkpoints.save(model, len(self.steps), record, plan)

    def listed_steps(self) -> list[dict[str, Any]]:
        """The records of the steps at the instants of ``[instants]`` (not the cut ones)."""
        return [s for s in self.steps if s["listed"]]


def slip_path(table: dict[str, Any], previous: dict[str, Any] | None) -> NDArray[np.float64]:
    """The accumulated sliding distance (m) at each interface point of a step's interface
    ``table``: the previous step's plus the length of this step's slip increment, |d slip|
    in 2-D, |(d slip1, d slip2)| in 3-D (the components in the tangent basis, fixed in
    time); ``previous``: the previous step's table (None: the first step)."""
    parts = ("slip1", "slip2") if "slip1" in table else ("slip",)
    now = np.array([table[c] for c in parts], dtype=float)               # (components, points)
    if previous is None or len(previous["slip"]) != now.shape[1]:
        return np.linalg.norm(now, axis=0)
    before = np.array([previous[c] for c in parts], dtype=float)
    return np.asarray(previous["slip_path"], dtype=float) + np.linalg.norm(now - before, axis=0)


def _outcome(d: dict[str, Any]) -> testtable.Outcome:
    """An Outcome from its dict (a checkpointed step's tests)."""
    o = testtable.Outcome(d["name"], d["field"], d["type"],
                          float("nan") if d["value"] is None else d["value"], d["reference"],
                          d["tolerance"], d["criterion"], d["ok"], d["samples"],
                          tuple(d["at"]) if d["at"] is not None else None)
    o.inst = d.get("inst")
    return o
