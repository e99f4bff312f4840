"""Newton's matrices when the tangent has a non-symmetric part.

With Coulomb's law in Newton (:mod:`xfemcontact.contact.nodal_problem`) the tangent of a
slipping interface is not symmetric: the traction of a slipping dof, -mu LAGS_C p,
depends on its pressure.  That part is small -- one column per slipping dof, on the
interface elements (the problem's :meth:`~xfemcontact.contact.problem.InterfaceProblem.coupling`)
-- while the rest is the symmetric matrix ``K`` MUMPS factorises as LDL^T (half the
memory and work of LU).  So:

* while nothing slips with its bound in Newton (no coupling), Newton solves with ``K``
  and the preconditioner of the options database (by default MUMPS LDL^T): a sticking
  interface costs what it always did, one factorisation;
* with a coupling, Newton's matrix is an AIJ copy of ``K`` plus the coupling, factorised
  by LU (``-pc_type lu`` with the database's ``-pc_factor_mat_solver_type``, MUMPS by
  default, and its ``-mat_mumps_*`` controls).  The copy is made only when something
  slips, kept between Jacobians (the LU analysis is reused while its pattern is), and
  freed when the coupling goes.

When the user chose ``-ksp_type``, the coupling is instead applied beside ``K``: Newton's
operator is ``K + C`` (a Python-type matrix) and the preconditioner is ``K`` with the
database's PC -- for instance ``-ksp_type gmres`` with the LDL^T factors of ``K`` (few
iterations: ``C`` has the rank of the slipping dofs; a Krylov method may break down
where the coupled tangent is nearly singular, which LU does not).

The matrices are swapped inside the Jacobian callback (:func:`prepare`): PETSc's Newton
line search SNES reads its Jacobian matrices after the callback returns.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Callable

from mpi4py import MPI

from xfemcontact._petsc import PETSc

if TYPE_CHECKING:
    from xfemcontact.contact.problem import InterfaceProblem


class _Sum:
    """Python context of the matrix ``K x + C x`` (the user's own Krylov method)."""

    def __init__(self, K: PETSc.Mat, problem: InterfaceProblem) -> None:
        self.K, self.problem = K, problem

    def mult(self, mat: PETSc.Mat, x: PETSc.Vec, y: PETSc.Vec) -> None:
        self.K.mult(x, y)
        C = self.problem.coupling()
        if C is not None:
            self.problem.add_product(C, x, y)


class CoupledJacobian:
    """The matrices Newton solves with (see the module documentation).

    ``K``: the assembled tangent (symmetric part); ``problem``: its interface problem;
    ``user_ksp``, ``user_pc``: the KSP and PC types the user gave (None: ours)."""

    def __init__(self, K: PETSc.Mat, problem: InterfaceProblem, user_ksp: str | None,
                 user_pc: str | None) -> None:
        self.K, self.problem = K, problem
        self.user_ksp, self.user_pc = user_ksp, user_pc
        self.A: PETSc.Mat | None = None          # AIJ: K plus the coupling
        self.shell: PETSc.Mat | None = None      # K + C applied (the user's Krylov method)
        self.pc_type: str | None = None          # the PC type of the symmetric solves
        self.coupled_jacobians = 0

    def prepare(self, snes: PETSc.SNES, jacobian: Callable[..., None]) -> None:
        """After the problem's tangent is in ``K``: give ``snes`` the matrices of this
        Newton iteration (``jacobian``: the callback, kept)."""
        C = self.problem.coupling()
        coupled = snes.getComm().tompi4py().allreduce(C is not None, op=MPI.LOR)
        pc = snes.getKSP().getPC()
        if self.pc_type is None:
            self.pc_type = pc.getType()
        if not coupled:
            self.release()
            if pc.getType() != self.pc_type:
                self._set_pc(pc, self.pc_type)
            snes.setJacobian(jacobian, self.K, self.K)
            return
        self.coupled_jacobians += 1
        if self.user_ksp:
            if self.shell is None:
                self.shell = PETSc.Mat().createPython(self.K.getSizes(), _Sum(self.K, self.problem),
                                                      comm=self.K.getComm())
                self.shell.setUp()
            self.shell.assemble()
            snes.setJacobian(jacobian, self.shell, self.K)
            return
        if self.A is None:
            self.A = PETSc.Mat()
        self.K.convert("aij", self.A)           # (petsc4py converts in place without a target)
        if C is not None:
            self.problem.add_matrices(self.A, C)
        self.A.assemble()
        if pc.getType() != "lu":
            self._set_pc(pc, "lu")
        snes.setJacobian(jacobian, self.A, self.A)

    @staticmethod
    def _set_pc(pc: PETSc.PC, kind: str) -> None:
        """The PC type ``kind`` with the factorisation package of the options database
        (a new type forgets it: PETSc's own factorisation would be used)."""
        pc.setType(kind)
        solver = PETSc.Options().getString("pc_factor_mat_solver_type", "")
        if solver and kind in ("lu", "cholesky", "ilu", "icc"):
            pc.setFactorSolverType(solver)

    def release(self) -> None:
        """Free the AIJ copy (nothing slips any more, or the solve is over)."""
        if self.A is not None:
            self.A.destroy()
            self.A = None
