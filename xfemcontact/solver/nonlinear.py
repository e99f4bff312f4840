"""Newton inside the outer loops of an interface problem: the SNES objects of one
model and the record of what they did.

    solver = NonlinearSolver(model)
    reason = solver.solve(model.x)       # > 0 converged
    solver.record, solver.info(), solver.warnings()

The Newton SNES (no prefix) calls the model's residual and Jacobian; the outer
loops (:mod:`xfemcontact.solver.loops`) are the ones ``model.problem.loops``
names, configured from the case's ``[contact]`` table and the options database.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable, Protocol

from xfemcontact._petsc import PETSc
from xfemcontact.solver.coupled import CoupledJacobian
from xfemcontact.solver.linesearch import MeritLineSearch
from xfemcontact.solver.loops import LoopRecord, create_loops, solve_newton
from xfemcontact.solver.newton import LoadRelativeTest, create_snes, user_value

if TYPE_CHECKING:
    from xfemcontact.case.load import Case
    from xfemcontact.contact.problem import InterfaceProblem
    from xfemcontact.dofs.layout import DofLayout


class SolvedModel(Protocol):
    """What the solver uses of its :class:`xfemcontact.model.Model` (which imports this
    module)."""

    case: Case
    comm: PETSc.Comm
    layout: DofLayout
    problem: InterfaceProblem | None
    K: PETSc.Mat
    load_norm: float

    def residual(self, snes: PETSc.SNES, x: PETSc.Vec, f: PETSc.Vec) -> None: ...

    def merit(self, x: PETSc.Vec, f: PETSc.Vec) -> float: ...

    def jacobian(self, snes: PETSc.SNES, x: PETSc.Vec, J: PETSc.Mat, P: PETSc.Mat) -> None: ...


def _mumps_count(v: float) -> int:
    """MUMPS writes large counts as negative millions."""
    return int(v) if v >= 0 else int(-v) * 1000000


class NonlinearSolver:
    """The SNES objects of one model and the record of the solve.

    Attributes: ``newton`` (SNES), ``newton_test`` (its convergence test, with the
    residual history), ``outer`` and ``contact`` (the outermost and the contact
    loop SNES, None without loops), ``record`` (:class:`LoopRecord`, None without
    loops), ``jacobians`` (Jacobian evaluations), ``linear_failure`` (KSP reason and
    MUMPS status of a failed factorisation, see :func:`solve_newton`) and
    ``linear_warnings``.
    """

    newton: PETSc.SNES
    newton_test: LoadRelativeTest
    record: LoopRecord | None
    outer: PETSc.SNES | None
    contact: PETSc.SNES | None

    def __init__(self, model: SolvedModel) -> None:
        self.model = model
        self.problem = model.problem
        self.comm = model.comm
        newton = model.case.newton
        f = model.layout.create_global_vec()
        self.jacobians = 0
        # a semi-smooth Newton has converged when its statuses stop changing, and the
        # rows of the conditions at the dofs are kinematic (m^2): they are converged as
        # such, weighed into forces (a stick row violated by a whole slip increment
        # weighs D |slip|, far below the loads)
        settled = getattr(model.problem, "friction_settled", None)
        scaled = getattr(model.problem, "residual_norm", None)
        self.newton, self.newton_test = create_snes(
            self.comm, model.residual, self._jacobian, model.K, f,
            newton.resi_glob_rela, newton.iter_glob_maxi, lambda: model.load_norm,
            settled=settled, scaled=scaled)
        # a tangent with a non-symmetric part (Coulomb's law in Newton): solver/coupled.py
        self.coupled = (CoupledJacobian(model.K, model.problem, user_value("ksp_type"), user_value("pc_type"))
                        if model.problem is not None else None)
        self.linear_failure: dict[str, Any] | None = None
        self.linear_warnings: list[str] = []
        #: set by the model where a coarse start applies (2-D contact)
        self.coarse_start: Callable[[PETSc.Vec], dict[str, Any] | None] | None = None
        self._info: dict[str, Any] | None = None
        problem = model.problem
        self.record = LoopRecord() if problem is not None and problem.loops else None
        self.outer = self.contact = None
        if problem is not None and self.record is not None:
            self.outer, self.contact = create_loops(self, problem, model.case.contact)
        # Newton's steps damped on the problem's merit function (solver/linesearch.py), unless
        # the user chose a line search
        self.line_search: MeritLineSearch | None = None
        if problem is not None and problem.line_search and user_value("snes_linesearch_type") is None:
            work: list[PETSc.Vec] = []          # made at the first merit evaluation (a sticking run has none)

            def merit(x: PETSc.Vec) -> float:
                if not work:
                    work.append(f.duplicate())
                return model.merit(x, work[0])

            self.line_search = MeritLineSearch(self.newton, merit, problem)
            self.newton.setLineSearchPreCheck(self.line_search)

    def _jacobian(self, snes: PETSc.SNES, x: PETSc.Vec, J: PETSc.Mat, P: PETSc.Mat) -> None:
        self.jacobians += 1
        self.model.jacobian(snes, x, self.model.K, self.model.K)
        if self.coupled is not None:
            self.coupled.prepare(snes, self._jacobian)

    def solve(self, x: PETSc.Vec) -> int:
        """Solve from ``x`` (updated in place); the outermost converged reason."""
        if self.outer is None:
            solve_newton(self, x)
            return int(self.newton.getConvergedReason())
        self.outer.solve(None, x)
        return int(self.outer.getConvergedReason())

    def warnings(self) -> list[str]:
        """The linear solver's warnings, then the loops' (one line each)."""
        return list(self.linear_warnings) + (list(self.record.warnings) if self.record else [])

    def release(self) -> None:
        """Free the factorisation (after the solve); the facts are kept for :meth:`info`."""
        if self._info is None:
            self._info = self.info()
            self.newton.getKSP().reset()
            if self.coupled is not None:
                self.coupled.release()

    def info(self) -> dict[str, Any]:
        """Linear solver facts: type, Jacobians, MUMPS statistics when MUMPS factors."""
        if self._info is not None:
            return self._info
        ksp = self.newton.getKSP()
        pc = ksp.getPC()
        info: dict[str, Any] = {"ksp": ksp.getType(), "pc": pc.getType(), "matrix": self.model.K.getType(),
                "jacobians": self.jacobians}
        if self.coupled is not None:
            info["coupled_jacobians"] = self.coupled.coupled_jacobians
        try:
            info["solver"] = pc.getFactorSolverType()
        except Exception:      # not a factorising preconditioner
            return info
        if info["solver"] == "mumps" and self.jacobians:
            try:
                F = pc.getFactorMatrix()
            except PETSc.Error:     # dropped after a failed factorisation (solve_newton)
                if self.linear_failure is not None and self.linear_failure["mumps"]:
                    info["mumps"] = self.linear_failure["mumps"]
                return info
            info["mumps"] = {"null_pivots": int(F.getMumpsInfog(28)),
                             "status": int(F.getMumpsInfog(1)),
                             "factor_entries": _mumps_count(F.getMumpsInfog(29)),
                             "ordering": int(F.getMumpsInfog(7)),
                             "memory_mb_total": int(F.getMumpsInfog(31))}
        return info

    def iterations(self) -> dict[str, Any]:
        """Iteration counts of every loop (results.json ``iterations``)."""
        loops = self.record
        if loops is None:
            return {"newton": self.newton.getIterationNumber()}
        coarse = loops.coarse or {}
        return {"newton": int(sum(loops.newton)) + int(coarse.get("newton", 0)),
                "coarse_start": coarse or None, "newton_per_solve": list(loops.newton),
                "contact": list(loops.contact), "friction": int(loops.friction),
                "stick_predictor_steps": int(sum(loops.newton_predictor)),
                "line_search_retries": int(loops.line_search_retries),
                "frozen_status_solves": int(loops.frozen_solves),
                "status_changes": list(loops.status_changes),
                "damped_steps": self.line_search.damped if self.line_search else 0,
                "merit_evaluations": self.line_search.evaluations if self.line_search else 0,
                "threshold_changes": [float(c) for c in loops.threshold_changes]}
