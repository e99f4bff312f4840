"""Newton's steps globalised on a merit function: a non-monotone backtracking line search.

A semi-smooth Newton on contact and Coulomb friction (:mod:`xfemcontact.contact.nodal_problem`,
2-D, Coulomb's law in Newton) converges fast near a solution, but its full steps can cycle
through statuses far from it (the Schur complement of the active sets is no P-matrix: Coulomb's
coupling, tiny lumped weights).  The problem gives the conditions as functions of the iterate
alone (Alart and Curnier's complementarity functions, :func:`xfemcontact.contact.nodal.complementarity`),
whose squared norm with the equilibrium rows, theta(x), is a merit function; Newton's statuses
being the branches of those functions at the iterate, its step d is a descent direction,
theta'(x; d) = -2 theta(x) (measured by finite differences at every iterate of the arc under
shear: within 5e-2 of it, tests/test_friction_newton.py::test_merit_descent).
Each Newton step is then taken with the largest alpha = 2^-k (k < :data:`HALVINGS`, else
2^-HALVINGS) that satisfies the non-monotone Armijo condition of Grippo, Lampariello and Lucidi (1986),

    theta(x + alpha d) <= max(theta of the last MEMORY iterates) - 2 SIGMA alpha theta(x),

statuses re-evaluated at each trial point.  A trial costs one residual evaluation, no
factorisation.  The full step is taken whenever the merit function allows it, so that the local
(superlinear) convergence of the semi-smooth Newton is kept.

When the best merit value of the solve has not halved over :data:`STALL` iterations the
problem is told (``stall()``): Newton with Coulomb's law in it has stalled, and the problem goes
on with the threshold fixed point until it has settled (:mod:`xfemcontact.contact.nodal_problem`,
the guard).  What stalls it: the inclusion held by contact and friction alone
(cases/campaign/curved_inclusion_mixed_quad8.toml), where every contact dof slips at the first
iterate after the sticking start (whose multipliers oscillate from dof to dof: the weak modes of
the multiplier space on that mesh), which leaves the inclusion's rotation free: the tangent is
nearly singular while its few sticking dofs are not found (the merit value stays within 1e4 ..
1e6).  With the bound mu |LAGS_C| (before the augmented one) straight interfaces at the Coulomb
limit on unstructured cells stalled too (limit-D_q8u3x2_a+20_gen_nu0 of bench/campaign.py): a
dof of small lumped weight closing with LAGS_C = 0 got no friction, and found no status
consistent with the others' (released it interpenetrated by 1e-9 m, in contact it pulled by the
pressure's order); with the augmented bound it slips at once (7 Newton iterations, 25 before).

Implemented as the pre-check of PETSc's line search (``SNESLineSearchSetPreCheck``): the
step PETSc's own line search (``basic``: full steps, the default) then takes is the damped one.
Not used when the user chose ``-snes_linesearch_type``.

The default in 2-D, with the augmented bound of Coulomb's law
(:mod:`xfemcontact.contact.nodal_problem`); ``-xfc_friction_line_search NONE`` gives full steps
and the cycle guard, the method of earlier versions.  Measured against full steps on the sliding campaign
(``bench/campaign.py``, 40 cases, 480 runs: every converged answer the same to 1.5e-10 of the
scales where the closed forms hold), the Newton iterations: the curved cases 34, 25, 23, 16, 15
-> 15, 15, 13, 9, 10, the straight ones at the Coulomb limit 21 -> 7, 12 -> 5, 12 -> 14,
open-D_q8u_a+60 6 -> 8; cases/validation/ low_friction 30 -> 14, history_cut 16 -> 8,
history_open_reclose 25 -> 15, history_shear_cycle 20 -> 22; the inclusion on quadrangles
474 -> 278 (it stalls, see above).  On the arc on Gmsh quadrangles it ends on another solution
of the conditions at the dofs than full steps did (LAGS_C up to 1.9e-3 Pa apart near the end of
the stick zone; both satisfy every condition at the dofs to round-off).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable

if TYPE_CHECKING:
    from xfemcontact._petsc import PETSc

#: Armijo's sufficient decrease
SIGMA = 1e-4
#: the non-monotone reference: the largest merit value of this many last iterates (Grippo,
#: Lampariello and Lucidi).  Measured (Newton iterations, arc QUAD8 / arc Gmsh / inclusion
#: TRIA6 / SSNV509 mu = 0.2 QUAD8 / TRIA6 / low_friction): monotone (1) 54 / 17 / 18 / 23 / 19 / 21;
#: 5: 18 / 23 / 20 / 14 / 11 / 14; 10: 18 / 22 / 19 / 33 / 11 / 16
MEMORY = 5
#: halvings of the step before the smallest one (2^-HALVINGS) is taken
HALVINGS = 12
#: iterations over which the best merit value of a solve must halve (see the module docstring).
#: Measured (Newton iterations, MEMORY 5; the curved cases above, then limit-D_q8u3x2_a+20,
#: limit-T_q8s_a+30, limit-T_t6s20_a+27 of the straight campaign, 21 / 12 / 14 with the cycle
#: guard): 8 leaves the curved cases untouched and the straight ones at 25 / 24 / 16; 6: 23 /
#: 22 / 16; 12: 37 / 28 / 16.  What the inclusion QUAD8 takes after the hand-over depends on
#: the iterate it starts from, not monotonically: 462 and 4 forced status loops with 8 (474 and
#: 6 with the cycle guard), 235 with 6, 42 with 12, 438 with 10, 257 with 14; on 40 x 40 cells 65
#: with 8, 30 with 12 (100 with the cycle guard)
STALL = 8


#: an iterate whose merit value equals (to this, relative) one met before in the solve is taken
#: as a cycle: its step must decrease the merit function itself (the monotone Armijo test), not
#: only the largest of the last MEMORY values, which a cycle of full steps of period 2 satisfies
#: at every step (measured on cases/validation/history_open_reclose.toml before the augmented
#: bound: merit values 291.76 and 360.76 in turn for 5 iterations, the reference 366.7)
REPEAT = 1e-12


class MeritLineSearch:
    """The pre-check of a Newton SNES (see the module docstring).

    ``merit(x)``: theta(x) = |Phi(x)|^2; ``problem``: has ``merit_active`` (whether to
    damp now) and ``stall()``.  Counts ``damped`` steps and merit ``evaluations``."""

    def __init__(self, snes: PETSc.SNES, merit: Callable[[PETSc.Vec], float], problem: Any) -> None:
        self.snes, self.merit, self.problem = snes, merit, problem
        self.history: list[float] = []
        self.damped = 0
        self.evaluations = 0
        self.stalls = 0
        self._w: PETSc.Vec | None = None

    def _theta(self, x: PETSc.Vec) -> float:
        self.evaluations += 1
        return self.merit(x)

    def __call__(self, x: PETSc.Vec, y: PETSc.Vec) -> bool:
        """Scale the step ``y`` (PETSc's: the new iterate is x - y) by alpha; True if changed."""
        if self.snes.getIterationNumber() == 0:
            self.history = []
        if not self.problem.merit_active:
            return False
        theta = self._theta(x)
        self.history.append(theta)
        best_before = min(self.history[:-STALL], default=None)
        if best_before is not None and min(self.history[-STALL:]) > 0.5 * best_before:
            self.problem.stall()
            self.stalls += 1
            self.history = []
            return False
        reference = max(self.history[-MEMORY:])
        if any(abs(theta - t) <= REPEAT * theta for t in self.history[:-1]):
            reference = theta                # a merit value met again: a cycle, see REPEAT
        if self._w is None:
            self._w = x.duplicate()
        w, alpha = self._w, 1.0
        for _ in range(HALVINGS):
            w.waxpy(-alpha, y, x)
            if self._theta(w) <= reference - 2.0 * SIGMA * alpha * theta:
                break
            alpha *= 0.5
        if alpha == 1.0:
            return False
        self.damped += 1
        y.scale(alpha)
        return True

    def release(self) -> None:
        if self._w is not None:
            self._w.destroy()
            self._w = None
