"""code_aster's contact loops as SNES outer iterations (Python-type SNES).

Innermost first:

* Newton (the SNES with no prefix): statuses and thresholds frozen, to
  RESI_GLOB_RELA (``-snes_rtol``);
* the contact status loop (SNES prefix ``contact_``): after each Newton solve
  the status test is applied, until no point changes (at most ITER_CONT_MAXI,
  ``-contact_snes_max_it``).  Its monitored "norm" is the number of interface
  Gauss points whose status changed.  As in code_aster, with friction reaching
  the limit is a warning (forced convergence, alarm CONTACT3_86), without it an
  error;
* the friction threshold loop (prefix ``friction_``): s <- LAGS_C, until LAGS_C
  changes by less than RESI_FROT relative (``-friction_snes_rtol``), at most
  ITER_FROT_MAXI (``-friction_snes_max_it``); at least two iterations run
  (the first reference is zero), except in a load step after the first, whose
  thresholds come from the previous step's solution.  Its "norm" is that relative change.
  While the thresholds are far from converged (last change above ``INEXACT_ABOVE``)
  a threshold iteration runs ``INEXACT_ITERATIONS`` status iterations only: statuses
  and thresholds then converge together, and the loop cannot stop on an iteration
  whose statuses were still changing.  ITER_FROT_MAXI counts the iterations whose
  status loop ran to its end; at most as many cut ones come on top.

Without SEUIL_INIT (or with 0) the first threshold iteration is frictionless,
as in code_aster.  With statuses frozen that is a linear problem, so its
Newton converges in a step or two -- unless a part is held only by friction
(a block on an incline under its own weight): the frictionless problem then
has no solution.  After ``FREE_START_ITERATIONS`` Newton iterations without
convergence the iteration is restarted from the initial state with friction
unbounded (every point in contact sticks, what a large |SEUIL_INIT| does),
and a warning says so.

Line search on failure: Newton takes full steps, as code_aster does (a
backtracking line search stalls on sliding interfaces whose statuses must
flip all at once).  But full steps can wander off on a nearly free body
whose interface slips almost everywhere; a Newton solve that fails with
friction on is therefore redone once, from the same start, with
``-snes_linesearch_type bt`` (unless the user chose a line search).

Stick predictor: where a threshold update bounds friction for the first time
(the threshold was zero or unbounded: no SEUIL_INIT, SEUIL_INIT = 0, or a
point that came into contact), the tangential jump and friction dof of the
previous solution are no answer of the bounded law -- a frictionless start
may even leave an arbitrary rigid rotation of an inclusion, on which a
slipping interface has no stiffness and Newton stalls.  One Newton step is
then taken with those points held in the stick branch (a linear problem,
solved exactly), and Newton with the real law starts from there.  A loop
that sticks everywhere converges at that step without another factorisation.

``-contact_snes_monitor`` / ``-friction_snes_monitor`` print them.
"""
from __future__ import annotations

from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, Callable, Iterator, Protocol

import numpy as np

from xfemcontact._petsc import PETSc

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.case.load import Contact
    from xfemcontact.contact.problem import InterfaceProblem
    from xfemcontact.solver.newton import LoadRelativeTest

Reason = PETSc.SNES.ConvergedReason

#: Newton iterations allowed to the frictionless first threshold iteration (a
#: linear problem once statuses are frozen) before it is taken as having no solution
FREE_START_ITERATIONS = 3
#: most Newton solves with frozen friction statuses, and the status changes after
#: which a point keeps its status (see ContactLoop._frozen_statuses)
FROZEN_SOLVES = 30
MAX_FLIPS = 3
#: factorisations redone with more MUMPS work space after INFOG(1) = -8 / -9
WORKSPACE_RETRIES = 3
#: status iterations allowed in a threshold iteration whose thresholds are still far
#: from converged (the previous relative change above INEXACT_ABOVE): its statuses
#: only feed the next thresholds, and the active sets of wrong thresholds may cycle
#: (measured on the sliding campaign: 295 -> 56, 88 -> 29, 74 -> 15 Newton
#: iterations with 1; 83, 42, 20 with 3; the same with INEXACT_ABOVE 1e-1 ... 1e-6;
#: below 2e-2 a wavy interface whose thresholds converge from 1e-3 cycled with
#: period 2 between cut iterations: 11 -> 56 Newton iterations)
INEXACT_ITERATIONS = 1
INEXACT_ABOVE = 0.1


class LoopRecord:
    """Iteration counts of every loop, for results.json."""

    def __init__(self) -> None:
        self.newton: list[int] = []           # Newton iterations of every Newton solve
        self.contact: list[int] = []          # status iterations of every contact loop
        self.friction = 0
        self.newton_predictor: list[int] = []  # Newton iterations (0 or 1) of every stick predictor
        self.line_search_retries = 0  # full-step Newton solves redone with a line search
        self.frozen_solves = 0     # Newton solves with frozen friction statuses
        self.status_changes: list[int] = []   # changes after every Newton solve
        self.threshold_changes: list[float] = []
        self.warnings: list[str] = []
        self.coarse: dict[str, Any] | None = None   # the coarse start's solve, if one ran


class Solver(Protocol):
    """What the loops use of their :class:`~xfemcontact.solver.nonlinear.NonlinearSolver`
    (which imports this module)."""

    newton: PETSc.SNES
    newton_test: LoadRelativeTest       # Newton's convergence test
    problem: InterfaceProblem | None    # the model's interface problem
    record: LoopRecord | None           # not None when the problem has loops
    linear_failure: dict[str, Any] | None
    linear_warnings: list[str]
    #: the model's coarse start (:meth:`xfemcontact.model.Model.coarse_start`), None without
    coarse_start: Callable[[PETSc.Vec], dict[str, Any] | None] | None

    def info(self) -> dict[str, Any]: ...


def _python_snes(comm: PETSc.Comm, prefix: str, context: ContactLoop | FrictionLoop, max_it: int,
                 rtol: float = 0.0) -> PETSc.SNES:
    snes = PETSc.SNES().create(comm=comm)
    snes.setOptionsPrefix(prefix)
    snes.setType(PETSc.SNES.Type.PYTHON)
    snes.setPythonContext(context)
    snes.setTolerances(rtol=rtol, max_it=max_it)
    return snes


class ContactLoop:
    """Status fixed point around Newton."""

    def __init__(self, solver: Solver, problem: InterfaceProblem) -> None:
        assert solver.record is not None             # the solver of a problem with loops has one
        self.solver, self.problem = solver, problem
        self.newton, self.record = solver.newton, solver.record
        self.retry = True            # off while the frictionless start is being tried
        self.budget = None           # fewer status iterations (an inexact threshold iteration)
        self.truncated = False       # the last solve stopped at its budget

    def view(self, snes: PETSc.SNES, viewer: PETSc.Viewer) -> None:
        viewer.printfASCII("contact status loop (code_aster ITER_CONT_MAXI)\n")

    def solve(self, snes: PETSc.SNES, b: PETSc.Vec | None, x: PETSc.Vec) -> None:
        problem, newton = self.problem, self.newton
        max_it = snes.getTolerances()[3]
        self.truncated = False
        if self.budget is not None and self.budget < max_it:
            max_it, self.truncated = self.budget, True
        for k in range(1, max_it + 1):
            self._newton(x)
            if newton.getConvergedReason() <= 0:
                snes.setIterationNumber(k)
                snes.setConvergedReason(Reason.DIVERGED_INNER)
                self.record.contact.append(k)
                return
            changed = problem.update_status(x)
            if changed:
                problem.equations_changed = True
            self.record.status_changes.append(changed)
            snes.setIterationNumber(k)
            snes.setFunctionNorm(float(changed))
            snes.monitor(k, float(changed))
            if changed == 0:
                self.record.contact.append(k)
                self.truncated = False
                snes.setConvergedReason(Reason.CONVERGED_FNORM_ABS)
                return
        self.record.contact.append(max_it)
        if self.truncated:           # the threshold loop goes on: no alarm
            snes.setConvergedReason(Reason.CONVERGED_ITS)
        elif problem.friction:
            self.record.warnings.append(
                f"contact statuses still changing after ITER_CONT_MAXI = {max_it} iterations "
                f"({changed} points): convergence forced, as code_aster does with friction "
                f"(alarm CONTACT3_86); check for interpenetration or use smaller load steps")
            snes.setConvergedReason(Reason.CONVERGED_ITS)
        else:
            snes.setConvergedReason(Reason.DIVERGED_MAX_IT)

    def _newton(self, x: PETSc.Vec) -> None:
        """Newton from ``x``.  With friction, a full-step Newton that fails is redone once
        from the same start with a backtracking line search (module docstring)."""
        newton = self.newton
        retry = self.problem.fallbacks and self.problem.friction and self.retry
        start = x.copy() if retry else None
        solve_newton(self.solver, x)
        self.record.newton.append(newton.getIterationNumber())
        if newton.getConvergedReason() > 0 or start is None:
            return
        if _line_search(newton) != "basic":      # the user chose a line search: theirs stands
            return
        start.copy(x)
        with _newton_settings(newton, line_search="bt"):
            solve_newton(self.solver, x)
        self.record.newton.append(newton.getIterationNumber())
        self.record.line_search_retries += 1
        if newton.getConvergedReason() > 0:
            self._warn_once("Newton with full steps (code_aster's) did not converge in a threshold "
                            "iteration; it was redone from the same start with a backtracking line "
                            "search (-snes_linesearch_type bt)")
            return
        start.copy(x)
        self._frozen_statuses(x)

    def _frozen_statuses(self, x: PETSc.Vec) -> None:
        """Newton with the friction statuses frozen (each solve is then linear), the
        statuses updated from the result until they stop changing, then Newton with
        the real law from there.  A point that has changed ``MAX_FLIPS`` times keeps
        its status (no cycling)."""
        problem, newton = self.problem, self.newton
        mpi = problem.comm.tompi4py()
        status = problem.friction_statuses(x)
        flips = np.zeros(status.shape, dtype=np.int64)
        for _ in range(FROZEN_SOLVES):
            with problem.holding(status):
                solve_newton(self.solver, x)
            self.record.newton.append(newton.getIterationNumber())
            self.record.frozen_solves += 1
            if newton.getConvergedReason() <= 0:
                break
            new = problem.friction_statuses(x)
            flips += new != status
            new = np.where(flips > MAX_FLIPS, status, new)
            if not mpi.allreduce(int(np.count_nonzero(new != status))):
                break
            status = new
        solve_newton(self.solver, x)
        self.record.newton.append(newton.getIterationNumber())
        if newton.getConvergedReason() > 0:
            self._warn_once("Newton did not converge in a threshold iteration, with full steps nor with "
                            "a line search (points at the stick/slip limit); it converged with the "
                            "friction statuses frozen in Newton and updated between solves")

    def _warn_once(self, text: str) -> None:
        if text not in self.record.warnings:
            self.record.warnings.append(text)


def solve_newton(solver: Solver, x: PETSc.Vec) -> None:
    """``solver.newton.solve`` from ``x``; a failed factorisation is dropped after it.

    When MUMPS fails (a numerically singular matrix, INFOG(1) = -10) PETSc 3.18's
    interface skips every later numeric factorisation of that factor, and the
    next solve (a fallback from the same start) would stop on MUMPS INFOG(1) = -3
    with a traceback.  The KSP is therefore reset: the next solve analyses and
    factorises anew.  What failed is kept in ``solver.linear_failure`` (KSP reason,
    MUMPS INFOG(1)) for the diagnostics.

    When the problem's equations changed since the last solve (``equations_changed``: a
    status loop changed statuses, a dependent vertex of the nodal problem switched modes)
    Newton takes at least one iteration: a start within RESI_GLOB_RELA of the new equations
    is not their solution (measured: the arc under a stronger shear, dx = 4e-6 m in
    cases/campaign/curved_arc_shear_quad8.toml, ended with the conditions at the dofs
    violated by 6e-9 of their scales when its status loop changed a status after Newton's
    convergence and the next Newton accepted its start).

    When MUMPS ran out of work space (INFOG(1) = -8, -9: pivoting of the
    indefinite tangent delayed more than the analysis foresaw, which happens at
    random on small problems over several processes) the memory relaxation
    ICNTL(14) is doubled and Newton goes on from where it stopped, at most
    ``WORKSPACE_RETRIES`` times, with a warning.
    """
    newton = solver.newton
    problem = solver.problem
    force = bool(problem is not None and problem.equations_changed)
    if problem is not None:
        problem.equations_changed = False
    solver.newton_test.force_iteration = force
    for _ in range(WORKSPACE_RETRIES + 1):
        newton.solve(None, x)
        if newton.getConvergedReason() != Reason.DIVERGED_LINEAR_SOLVE:
            return
        ksp = newton.getKSP()
        info = solver.info() or {}
        mumps = info.get("mumps") or {}
        solver.linear_failure = {"ksp_reason": int(ksp.getConvergedReason()), "mumps": info.get("mumps")}
        ksp.reset()
        if mumps.get("status") not in (-8, -9):
            return
        relaxation = _raise_workspace(newton)
        solver.linear_warnings.append(
            f"MUMPS ran out of work space (INFOG(1) = {mumps['status']}): the memory relaxation "
            f"-mat_mumps_icntl_14 was raised to {relaxation} % and the factorisation redone")


def _raise_workspace(newton: PETSc.SNES) -> int:
    """Double MUMPS' memory relaxation ICNTL(14) (percent, default 20) in the options
    database for the next factorisation of ``newton``; returns the new value."""
    opts = PETSc.Options()
    key = (newton.getOptionsPrefix() or "") + "mat_mumps_icntl_14"
    value = 2 * max(opts.getInt(key, 20), 10)
    opts.setValue(key, str(value))
    return value


def _line_search(snes: PETSc.SNES, kind: str | None = None) -> str:
    """The line search type of ``snes`` in the options database; with ``kind``, set it
    first (petsc4py 3.18 has no SNESLineSearch object: through the options)."""
    opts, key = PETSc.Options(), snes.getOptionsPrefix() + "snes_linesearch_type"
    if kind is not None:
        opts.setValue(key, kind)
        snes.setFromOptions()
    return opts.getString(key, "basic")


@contextmanager
def _newton_settings(newton: PETSc.SNES, max_it: int | None = None,
                     line_search: str | None = None) -> Iterator[None]:
    """Newton with at most ``max_it`` iterations and/or another line search for a
    block, restored after it."""
    old_it, old_search = newton.getTolerances()[3], _line_search(newton)
    try:
        if max_it is not None:
            newton.setTolerances(max_it=min(max_it, old_it))
        if line_search is not None:
            _line_search(newton, line_search)
        yield
    finally:
        newton.setTolerances(max_it=old_it)
        if line_search is not None:
            _line_search(newton, old_search)


class FrictionLoop:
    """Threshold fixed point around the contact loop."""

    def __init__(self, solver: Solver, problem: InterfaceProblem, contact: PETSc.SNES) -> None:
        assert solver.record is not None             # the solver of a problem with loops has one
        self.solver, self.problem, self.contact = solver, problem, contact
        self.record = solver.record

    def view(self, snes: PETSc.SNES, viewer: PETSc.Viewer) -> None:
        viewer.printfASCII("friction threshold loop (code_aster ITER_FROT_MAXI, RESI_FROT)\n")

    def solve(self, snes: PETSc.SNES, b: PETSc.Vec | None, x: PETSc.Vec) -> None:
        problem = self.problem
        rtol, _, _, max_it = snes.getTolerances()
        loop = self.contact.getPythonContext()
        change = np.inf
        exact = inexact = 0              # threshold iterations with a whole / a cut status loop
        k = 0
        while exact < max_it:
            k += 1
            if k > 1:
                if k == 2 and self.solver.coarse_start is not None and problem.wants_coarse_start(x):
                    self.record.coarse = self.solver.coarse_start(x)
                switched_on = problem.update_threshold(x)
                if problem.comm.tompi4py().allreduce(int(switched_on.sum())):
                    self._stick_predictor(switched_on, x)
                cut = change > INEXACT_ABOVE and inexact < max_it and exact < max_it - 1
                loop.budget = INEXACT_ITERATIONS if cut else None
                try:
                    self.contact.solve(None, x)
                finally:
                    loop.budget = None
            else:
                self._first_iteration(x)
            if self.contact.getConvergedReason() <= 0:
                snes.setIterationNumber(k)
                snes.setConvergedReason(Reason.DIVERGED_INNER)
                self.record.friction = k
                return
            if loop.truncated:
                inexact += 1
            else:
                exact += 1
            # thresholds carried from a converged load step are a true reference: the
            # loop may stop at its first iteration; otherwise the first reference is 0
            carried = problem.carried_thresholds
            change = problem.threshold_change(x, first=k == 1 and not carried)
            self.record.threshold_changes.append(change)
            snes.setIterationNumber(k)
            snes.setFunctionNorm(change)
            snes.monitor(k, change)
            self.record.friction = k
            if (k > 1 or carried) and change < rtol and not loop.truncated:
                snes.setConvergedReason(Reason.CONVERGED_FNORM_RELATIVE)
                return
        snes.setConvergedReason(Reason.DIVERGED_MAX_IT)

    def _first_iteration(self, x: PETSc.Vec) -> None:
        """The contact loop with the initial thresholds; a frictionless start that
        finds no equilibrium is redone with friction unbounded (module docstring)."""
        problem, newton = self.problem, self.solver.newton
        if problem.has_thresholds():
            self.contact.solve(None, x)
            return
        x0, state0 = x.copy(), problem.snapshot()
        loop = self.contact.getPythonContext()
        loop.retry = False
        try:
            with _newton_settings(newton, max_it=FREE_START_ITERATIONS):
                self.contact.solve(None, x)
        finally:
            loop.retry = True
        if self.contact.getConvergedReason() > 0:
            return
        x0.copy(x)
        problem.restore(state0)
        problem.unbound_friction()
        self.record.warnings.append(
            "the frictionless start (SEUIL_INIT absent or 0) has no equilibrium: a part is held only by "
            "friction; the first threshold iteration was redone with every point in contact "
            "sticking (give seuil_init, the expected contact pressure, to start bounded)")
        self.contact.solve(None, x)

    def _stick_predictor(self, held: NDArray[np.bool_], x: PETSc.Vec) -> None:
        """One Newton step with the points ``held`` (mask) in the stick branch."""
        newton = self.solver.newton
        with self.problem.holding(np.where(held, 0.0, np.nan)), _newton_settings(newton, max_it=1):
            solve_newton(self.solver, x)
        self.record.newton_predictor.append(newton.getIterationNumber())


def create_loops(solver: Solver, problem: InterfaceProblem,
                 case_contact: Contact) -> tuple[PETSc.SNES | None, PETSc.SNES | None]:
    """The SNES of the outer loops ``problem.loops`` needs: ``(outermost, contact)``,
    both None without loops; ``case_contact``: the case's ``[contact]`` table."""
    if "contact" not in problem.loops:
        return None, None
    comm = problem.comm
    contact = _python_snes(comm, "contact_", ContactLoop(solver, problem), case_contact.iter_cont_maxi)
    contact.setFromOptions()
    if "friction" not in problem.loops:
        return contact, contact
    friction = _python_snes(comm, "friction_", FrictionLoop(solver, problem, contact),
                            case_contact.iter_frot_maxi, case_contact.resi_frot)
    friction.setFromOptions()
    return friction, contact
