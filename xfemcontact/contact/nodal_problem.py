"""Unilateral contact with Coulomb friction, conditions at the multiplier dofs
(``[contact] integration = "NOEUD"``, the default).

The equations are those of :mod:`xfemcontact.contact.nodal`.  The multiplier
field on a cut cell interpolates vertex values with the cell's linear
functions N_v >= 0: a carrier's value is its dof; a tied vertex's, a convex
combination of dofs; a weak vertex's (:mod:`xfemcontact.contact.space`), the
extrapolation of its root cell -- a combination with negative weights, which is
what keeps linear fields exact there.  An extrapolated value can leave the
admissible set (tension, a positive threshold, or a traction above the bound)
where a contact or stick zone ends.  Such a *dependent vertex* then takes a
convex combination of the same roots instead (admissible wherever the roots
are): within a threshold iteration the switch is one way, so the status loop
cannot cycle, and every vertex value, hence every point value LAGS_C(x) = sum
N_v lam(v), T(x) = sum N_v T(v), is admissible.  At each threshold update a
switched vertex whose extrapolation has become admissible goes back to it, so
that switches made far from the solution do not outlive it.

Statuses, thresholds and friction statuses of the dofs are stored per interface
element and carrier slot ``(k, m)``: every element holding a dof computes the
same value from the same assembled inputs, on every process.  The dependent
vertices are numbered over every process; their values are reduced over MPI.

Loops (the protocol of :mod:`xfemcontact.contact.problem`), with Coulomb's law in
Newton (``-xfc_friction_newton COULOMB``, the default):

* the first Newton solve sticks wherever CONTACT_INIT puts contact (friction
  unbounded, statuses held: a linear problem, well posed for a body held by the
  interface alone), whatever SEUIL_INIT;
* where that start breaks the law (2-D with the line search, the rich space), the model
  replaces it by the solution in the stable space (:meth:`wants_coarse_start`,
  :meth:`xfemcontact.model.Model.coarse_start`): Newton then starts near a smooth solution
  instead of the sticking state, whose rough multipliers sent it wandering on floating bodies;
* from there Newton (inner SNES) is a semi-smooth Newton on the whole law: at every
  Jacobian the contact statuses (the rules of :func:`nodal.contact_status`) and the
  friction statuses (:func:`nodal.friction_status`) are those of the iterate, and
  the friction bound of a dof is mu |LAGS_C| of the iterate, so that a slipping dof
  carries -mu LAGS_C p: its derivative couples the tangential traction to the
  pressure (:meth:`NodalContactProblem.coupling`, the non-symmetric part of the
  tangent, applied beside the factorised symmetric part:
  :mod:`xfemcontact.solver.operator`).  A converged Newton solve is a solution of the
  conditions of :mod:`xfemcontact.contact.nodal` with s = LAGS_C: the status and
  threshold loops then find nothing to change;
* 3-D: the slip direction of a slipping dof, p = q / |q| with q = T + r gt, is a function
  of the iterate, not a status: the residual takes it at the iterate, the tangent holds
  its derivative (:meth:`NodalContactProblem._direction_coupling`; the equilibrium then
  holds the slipping dof's own T, so that every derivative stays in an element block),
  and the statuses are which dofs slip.  For given statuses the problem is then smooth
  and Newton converges quadratically; it ends when the directions move by at most
  :data:`DIRECTION_SETTLED` as well;
* *guard*: active sets can cycle or chatter (their Schur complement is no P-matrix:
  the Coulomb coupling, tiny or negative lumped weights, stick/slip limits).  When
  Newton meets again statuses it has had in this threshold iteration, or a dof has
  changed its friction status :data:`CHATTER_FLIPS` times (3-D: statuses met again with
  directions within :data:`DIRECTION_CYCLE` of those they had), the load step goes on with
  the threshold fixed point below (the bound frozen at mu |LAGS_C| of the iterate, the
  contact statuses left to the status loop, its own safeguards; 3-D: the slip direction a
  function of the iterate in the tangent still, :attr:`_direction_in_newton`) until that loop has
  settled: when a status iteration changes nothing and the thresholds it leaves are within
  :data:`REARM_CHANGE` of the pressures, Coulomb's law goes back into Newton (the threshold
  loop converges linearly, Newton near the solution quadratically); the next load step
  starts with Coulomb's law in Newton again;
* 2-D, with the line search (``-xfc_friction_line_search MERIT``, the default; see
  :mod:`xfemcontact.solver.linesearch`): Newton's statuses are those of Alart and Curnier's
  augmented tests at the iterate with r = :data:`NEWTON_SCALE` E / h
  (:func:`nodal.contact_status_augmented`, :func:`nodal.friction_status_augmented`: a function of
  the iterate, so a slipping dof may reverse at once), the branches of the complementarity
  functions of :func:`nodal.complementarity`, and the friction bound is their augmented one,
  -mu min(0, LAGS_C + r gn) (:meth:`_augmented_pressure`; the same at a solution, where a dof in
  contact has gn = 0): a dof that closes has LAGS_C = 0 at the iterate, and the bound mu |LAGS_C|
  left it frictionless for a step.  The equilibrium then holds a slipping dof's own T, its row
  D (T - f) / rho_T (:meth:`_augmented_coupling`), so that the bound's derivative with respect
  to the gap stays in the elements' blocks.  Newton's step is a descent direction of the
  squared norm of those functions, and :mod:`xfemcontact.solver.linesearch` damps it when that
  merit function asks for it (a non-monotone backtracking line search).  Statuses met again
  or a chattering dof are then no cycle and hand nothing over; a stalled merit function hands
  over to the threshold fixed point as the guard does (:meth:`stall`).  Measured (Newton
  iterations over the whole run: full steps with the guard and the bound mu |LAGS_C| (NONE) /
  the line search with that bound / with the augmented bound): arc under shear QUAD8 34 / 18 /
  15 and Gmsh 25 / 23 / 15, SSNV509 mu = 0.2 QUAD8 23 / 14 / 13 and TRIA6 16 / 11 / 9,
  cases/validation/low_friction.toml 30 / 14 / 14, inclusion TRIA6 15 / 20 / 10, straight
  interfaces at the Coulomb limit on unstructured quadrangles (bench/campaign.py
  limit-D_q8u3x2_a+20, limit-D_q8u_a-30) 21 / 25 / 7 and 12 / 6 / 5,
  cases/validation/history_open_reclose.toml 25 / 40 / 15; the inclusion QUAD8 stalls and the
  threshold loop takes it (474 / 462 / 278 Newton iterations, status loops forced).

With ``-xfc_friction_newton TRESCA`` (the fixed point of earlier versions):

* Newton (inner SNES): contact statuses and thresholds fixed; the friction
  statuses are updated at every Jacobian from the current iterate, a
  semi-smooth Newton on friction (3-D: the slip direction is one of these statuses,
  not in the tangent: the directions converge over the threshold iterations, linearly);
* contact status loop: the contact rules after each Newton solve, and the
  switch of inadmissible dependent vertices;
* threshold loop: s <- LAGS_C at the dofs.  Without
  SEUIL_INIT the first threshold iteration sticks wherever there is contact
  (friction unbounded) instead of starting frictionless: the stick problem is
  well posed for a body held by the interface alone, the frictionless one is not.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from mpi4py import MPI

from xfemcontact import options
from xfemcontact._petsc import PETSc
from xfemcontact.contact import nodal
from xfemcontact.contact.dofmap import multiplier_dofs
from xfemcontact.contact.operator import InterfaceOperator
from xfemcontact.contact.problem import InterfaceProblem, InterfaceSetup
from xfemcontact.contact.scales import coefficients
from xfemcontact.contact.threshold import ThresholdUpdate

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.contact.operator import EndValues
    from xfemcontact.contact.problem import Remote
    from xfemcontact.contact.space import MultiplierSpace

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]
    #: the dof statuses and modes :meth:`NodalContactProblem.restore` takes back
    Snapshot = tuple[IntArray, FloatArray, FloatArray, BoolArray, bool, bool]
    #: LAGS_C, T, s, contact, sliding at the vertices of the segment cells, each (k, nv)
    VertexValues = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]

#: a weight below this (in absolute value) is taken as zero when looking for
#: dependent vertices (extrapolations with a negative weight)
NEGATIVE = -1e-14
#: after the first load step, pressures below this fraction of the largest one of the
#: previous steps are zero (see NodalContactProblem._lam_zero)
HISTORY_ZERO = 1e-9
#: in a cycle of contact statuses, a dof whose change rests on a pressure or a gap below
#: this fraction of its scale is degenerate (lambda ~ 0 and gap ~ 0: either status
#: solves the problem to that accuracy) and keeps its status
DEGENERATE = 1e-8
#: the range of the row scales COEF_CONT and mu COEF_FROT |p|, in units of E / h
ROW_SCALES = (1e-8, 1e8)
#: with Coulomb's law in Newton: a dof whose friction status changed this many times within a
#: threshold iteration ends it for the load step (the guard, module documentation).  Measured on
#: SSNV509 with mu = 0.3 (cases/validation/low_friction.toml), whose stick/slip limit chatters:
#: 107 Newton iterations without it; 70, 20, 33 and 21 (not converged) with 4, 6, 8 and 12.  With
#: 4 or 6 the arc on Gmsh quadrangles of the sliding campaign did not converge, with 8 it did
CHATTER_FLIPS = 8
#: with Coulomb's law in Newton, after the guard: Coulomb's law goes back into Newton at a
#: threshold update whose status iteration changed nothing and whose thresholds moved by at
#: most this (relative to the pressures, the threshold loop's norm).  Measured on the curved
#: cases of the sliding campaign and low_friction (Newton iterations without re-arming: arc
#: QUAD8 37, arc Gmsh 30, SSNV509 mu = 0.2 QUAD8 24 / Gmsh TRIA6 19, low_friction 33): 34,
#: 25, 23, 16, 30 with 1e-2; 33, 23, 22, 16 but 92 with 1e-1 (re-armed far from the solution,
#: Newton chattered again); 36, 27, 24, 17, 32 with 1e-3
REARM_CHANGE = 1e-2
#: a dof whose friction status changed this many times within one threshold iteration keeps
#: it until the next one (semi-smooth Newton can chatter between stick and slip near the
#: limits of wrong thresholds, SSNV509 with mu = 0.3 did, while Newton converges only when
#: the statuses have settled); the next threshold update frees it
MAX_FLIPS = 3
#: the scale of the slip in the friction status test (Pa/m, in units of E / h): the trial
#: traction T + STATUS_SCALE (E / h) gt (:func:`xfemcontact.contact.nodal.friction_status`).
#: Not COEF_FROT, so that the statuses take the same path whatever the coefficients (with
#: COEF_FROT, 1e-4 times its natural scale took 126 Newton iterations where the natural one
#: took 33); measured flat from 1e2 to 1e8 on the campaign's slowest cases
STATUS_SCALE = 1e4
#: 3-D, Coulomb's law in Newton: the slip direction of a slipping dof is that of T + DIRECTION_SCALE
#: (E / h) gt, a function of the iterate (in units of E / h; the status test keeps STATUS_SCALE).
#: At a solution T and gt are both along p, so the scale does not change the answer; it weighs
#: the slip against the traction in the tangent's rows of the slipping dofs, r b (I - p p^T) /
#: (|q| rho_T) (NodalContactProblem._direction_coupling), which at the start of a slipping step
#: (gt = 0, |q| = b) is r / rho_T.  Measured on cases/validation/history_turn3d_hexa20.toml, the
#: tangential traction across the slip (0 in closed form) after the step 2.5 -> 3: 3.6e-8 Pa with
#: r = STATUS_SCALE E / h, 5e-10 Pa with 1e2 E / h, 1.5e-11 Pa with E / h; 2 and 3 processes
#: against one 6.8e-10 and 1.5e-11 relative on the whole history
DIRECTION_SCALE = 1.0
#: 3-D, the threshold fixed point: a slip direction (unit vector in the tangent plane) whose
#: components moved by at most this is the same status and is not updated (a direction from a
#: trial traction carries the round-off of the slips: measured up to a few 1e-11 on 3
#: processes).  With Coulomb's law in Newton the direction is the iterate's, exactly
DIRECTION_CHANGE = 3e-11
#: 3-D, Coulomb's law in Newton: statuses met again (the same dofs slipping) are a cycle of the
#: guard when every slip direction is within this of the earlier one (component-wise).  A turn
#: of the slip within a load step passes through statuses met before with other directions (the
#: hysteresis turned from +y to -(1, 1) in one step: all slipping, all sticking, all slipping
#: again, (0, 1) and -(1, 1) / sqrt 2 1.7 apart in a component), which is no cycle
DIRECTION_CYCLE = 0.1
#: 3-D: Newton's statuses have settled when no direction moves by more than this (above
#: the round-off, so that Newton does not chase it; the directions it ends with are within
#: this of their limit, and LAGS_C within about 1e-10 of its scale: tests/test_contact3d.py).
#: With Coulomb's law in Newton the directions converge quadratically: a move this small
#: leaves the iterate at round-off (the residual test alone stopped the slip cases of
#: tests/test_contact3d.py one iteration earlier, LAGS_C up to 1.3e-10 relative off, 1.6e-13 with it)
DIRECTION_SETTLED = 1e-10
#: 3-D, after the guard (the bound frozen, the directions still in Newton's tangent): the
#: directions have settled when none moves by more than this.  Those Newton solves are steps
#: of the threshold loop, whose own test (RESI_FROT) and Coulomb's law back in Newton
#: (REARM_CHANGE) decide the accuracy of the answer; measured on the sphere under partial
#: slip (bench/contact3d_sphere.py, HEXA20 N = 6, mu = 0.3), directions there moved by 1e-8
#: at every iteration with the residual at 3e-14 of the loads, and DIRECTION_SETTLED ended
#: the run at ITER_GLOB_MAXI
GUARDED_DIRECTION_SETTLED = 1e-6
#: 2-D, Coulomb's law in Newton with the line search (``-xfc_friction_line_search MERIT``): the
#: scale r (in units of E / h) of the augmented tests that give Newton's statuses
#: and of the complementarity functions whose squared norm the line search decreases
#: (:func:`xfemcontact.contact.nodal.complementarity`).  The same r in both, so that Newton's
#: step descends the merit function; E / h weighs a slip like the traction it would build over a
#: cell, so that the kinks of the merit function (|T + r gt| = mu |LAGS_C|: a status changes) are
#: not packed within a small fraction of Newton's step.  Measured on the curved cases of the
#: sliding campaign and cases/validation/low_friction.toml (Newton iterations, arc QUAD8 / arc
#: Gmsh / inclusion TRIA6 / SSNV509 mu = 0.2 QUAD8 / TRIA6 / low_friction, solver/linesearch.py's
#: MEMORY 5): 18 / 23 / 20 / 14 / 11 / 14 with 1; 25 / 24 / 63 / 16 / 9 / 15 with 0.1; 18 / 34 /
#: 16 / 26 / 19 / 30 with 3.  With 1e4 (STATUS_SCALE; monotone line search) a kink lay within
#: 1e-3 of the step from the first iterate on: arc QUAD8 stalled (100 iterations), the others
#: took 46 / 69 / 12 / 15 / 32
NEWTON_SCALE = 1.0

#: the pressure scale of :meth:`NodalContactProblem.conditions` where every dof opens: this
#: fraction of E / h times the largest jump (the pressures are then round-off of the stresses
#: the loads cause, which the jumps measure only roughly)
OPEN_PRESSURE = 1e-3


class NodalContactProblem(InterfaceProblem):
    """Contact and friction at the multiplier dofs (see the module documentation)."""

    fallbacks = False
    friction_unknown = "traction"
    # facts of the protocol, never None here
    indices: IntArray
    rep_index: IntArray
    pattern_points: IntArray
    remote_points: Remote
    space: MultiplierSpace
    phi: FloatArray
    # state that starts unset (None)
    rho_T: float | None
    _kappa_rows: IntArray | None
    _h0: FloatArray | None
    _seen_contact: set[float]
    _seen_slip: set[float]

    def __init__(self, setup: InterfaceSetup) -> None:
        mesh, c = setup.mesh, setup.case.contact
        self.comm = mesh.comm
        self._mpi = self.comm.tompi4py()
        self.segments = setup.geo.segments() if mesh.dim == 2 else None
        self.points, self.space = setup.points, setup.space
        dofs = multiplier_dofs(mesh, setup.layout, setup.space, setup.points.cells)
        self.rep_index = dofs.rep_index
        self.pattern_points, self.remote_points = dofs.element_points, dofs.remote_points
        self.mu, self.friction = c.coulomb, c.friction
        self.loops = ("contact", "friction") if self.friction else ("contact",)
        self._op = op = InterfaceOperator(mesh, setup.geo, setup.layout, setup.space, self.rep_index,
                                          None, setup.points)
        self.indices = op.gidx
        self.phi = op.phi
        self.law = None
        self._nh, self._m = op.d * op.nn, op.nv
        self._nf = op.d - 1                       # friction components per dof (3-D: T1, T2)
        self.slot = self.rep_index >= 0                                  # (k, m) live slots
        self.fslot = self._tile(self.slot)                               # (k, nf m) friction slots
        self._y = setup.layout.create_global_vec()
        self._kinematics(mesh.element, setup.points)
        self._dependent_vertices()
        scales = coefficients(setup.case, mesh, setup.geo)
        self.warnings = []
        self._coef_frot, self._h = scales.coef_frot, scales.h
        self._kappa = setup.case.material.E / scales.h     # Pa/m: weighs the rows of the dofs
        #: Coulomb's law in Newton (module documentation); False: the threshold fixed point
        self.coulomb_newton = options.get("friction_newton", "COULOMB") == "COULOMB"
        #: 2-D, Coulomb's law in Newton: Newton's statuses those of the augmented tests at the
        #: iterate, its steps damped on the merit function (:meth:`merit_norm`), and a stalled
        #: merit function, not statuses met again or a chattering dof, what hands over to the
        #: threshold fixed point (:meth:`stall`): with a line search statuses met again are no
        #: cycle (the iterates differ), while full steps cycled (SSNV509 with mu = 0.3,
        #: cases/validation/low_friction.toml, met the same 7 statuses over and over without
        #: the guard; damped on the merit function it converged in 14 Newton iterations).
        #: False: full steps and the guard
        wanted = options.get("friction_line_search", "MERIT") == "MERIT"
        self.line_search = wanted and self.coulomb_newton and self.friction and self._nf == 1
        if wanted and not self.line_search and "friction_line_search" in options.given():
            self.warnings.append(
                "-xfc_friction_line_search MERIT applies to Coulomb friction in 2-D with Coulomb's law "
                "in Newton only: ignored here (" + ("3-D" if self._nf > 1 else "no friction" if not self.friction
                                                     else "-xfc_friction_newton TRESCA") + ")")
        self._given = (c.coef_cont, c.coef_frot)
        self._kappa_rows = None
        if self.coulomb_newton:
            # the rows of inactive and slipping dofs are scaled by E/h: COEF_CONT and COEF_FROT
            # would only scale them (the conditions hold exactly whatever the scales), and a
            # scale far from the others' lets round-off decide statuses at their limits
            # (measured: COEF_CONT = 1e4 E/h ended two curved campaign cases after 30 Newton
            # iterations, 25 and 18 with E/h)
            self.rho_n, self.rho_T = self._kappa, self._kappa
        else:
            self.rho_n = self._row_scale(scales.coef_cont, "coef_cont", "Pa/m")
            self.rho_T = None                                             # Pa/m, see _set_rho_T
        shape = self.rep_index.shape
        start = 1 if c.contact_init is not False else 0
        self.chi = np.where(self.slot, start, 0)                          # dof contact statuses
        fshape = (shape[0], self._nf * shape[1])
        self.slip = np.zeros(fshape)           # dof friction statuses (3-D: slip direction p1, p2)
        self.extrapolated = np.ones(self.n_dep, bool)                     # dependent vertices' mode
        self.guards = 0               # guards met (results.json)
        self.rearms = 0               # returns of Coulomb's law into Newton after a guard (results.json)
        self._settled = False         # the last status iteration changed nothing
        self.guarded = False          # the guard: the threshold fixed point for the rest of the step
        self._guard_now = False       # the same for one evaluation of the residual
        s0 = -abs(float(c.seuil_init)) if (c.seuil_init is not None and self.friction) else 0.0
        if self.coulomb_newton:
            s0 = 0.0                  # the first solve sticks (module documentation)
        self.unbounded = self.friction and s0 == 0.0         # first thresholds from a sticking solve
        self.free_start = False
        self.s = np.where(self.slot, s0, 0.0)
        #: with the line search, the thresholds of Newton's bound at the iterate: the augmented
        #: pressures (:meth:`_augmented_pressure`); ``s`` stays LAGS_C's, for the loops and results
        self._newton_s: FloatArray | None = None
        self._set_rho_T(abs(s0) if s0 else None)
        #: the dofs where the sticking start breaks the law (:meth:`wants_coarse_start`)
        self._start_broken: BoolArray | None = None
        self.held_convex = np.zeros(self.n_dep, bool)   # dependent vertices convex for D_a > 0
        self._functions()
        self._positive_weights()
        g = self.indices[:, self._nh:self._nh + self._m]
        lo, hi = self._y.getOwnershipRange()
        first = np.zeros(g.shape, bool)
        own = self.slot & (g >= lo) & (g < hi)
        first.flat[np.flatnonzero(own)[np.unique(g[own], return_index=True)[1]]] = True
        self._once = first                       # one slot per owned dof (inner products)
        ids = np.where(self.slot, self.space.representative(np.where(self.slot, self.space.carriers_of,
                                                                     self.space.ids[0])), -1)
        self._dof_id = ids                       # input id of each slot's dof (partition-free order)
        self._mark = ((ids * 2654435761) % 4294967296) / 4294967296.0 + 0.5
        self._seen_contact, self._seen_slip = set(), set()
        # Newton's (contact, friction) statuses in this threshold iteration (3-D: with the slip
        # directions they had, see _cycled)
        self._seen_states: dict[tuple[float, float], list[FloatArray]] = {}
        self._coupling: FloatArray | None = None
        self._flips = np.zeros(fshape, np.int64)   # friction status changes of each slot in this threshold iteration
        self._accelerated = self._threshold_update()
        self._h0 = None                          # jump dofs at the start of the step (None: 0)
        self._floor_lam = self._floor_gap = 0.0  # round-off scales of the previous steps
        self.carried_thresholds = False          # thresholds of a previous step's solution

    @property
    def _in_newton(self) -> bool:
        """Coulomb's law and the contact statuses are Newton's now (not in the sticking
        start, not after the cycle guard)."""
        return self.coulomb_newton and not (self.guarded or self._guard_now or self.unbounded
                                            or self.free_start)

    @property
    def merit_active(self) -> bool:
        """Whether Newton's steps are damped on the merit function now (:attr:`line_search`,
        and Coulomb's law in Newton: not in the sticking start, not after the guard)."""
        return self.line_search and self._in_newton

    def add_merit_residual(self, x: PETSc.Vec, f: PETSc.Vec) -> None:
        """Add to ``f`` the interface part of the merit function's equilibrium rows: every
        dof's LAGS_C and T in the equilibrium (the complementarity rows are
        :meth:`merit_norm`'s).  Keeps the complementarity values at the dofs for it."""
        ve, h, lam, T = self._values(x)
        gn = self._gap_and_tolerances(h, lam)[0]
        gt = self._mean_slip(h if self._h0 is None else h - self._h0, lam.shape)
        r = NEWTON_SCALE * self._kappa
        cn, ct = nodal.complementarity(lam, T, gn, gt, self.mu, r, self.friction)
        if self.bilateral:                       # GLISSIERE: always in contact
            cn = -r * gn
        self._merit_rows = (np.where(self.slot, cn, 0.0), np.where(self.fslot, ct, 0.0))
        Rh = (np.einsum("km,kmd->kd", np.where(self.slot, lam, 0.0), self._Bn)
              + np.einsum("km,kmd->kd", np.where(self.fslot, T, 0.0), self._Bt))
        live = self.indices[:, :self._nh] >= 0
        f.setValues(self.indices[:, :self._nh][live].astype(PETSc.IntType), Rh[live],
                    addv=PETSc.InsertMode.ADD_VALUES)
        f.assemblyBegin()
        f.assemblyEnd()

    def merit_norm(self, f: PETSc.Vec) -> float:
        """The merit function's norm (N/m): the rows of the jump and displacement dofs of
        ``f`` (:meth:`add_merit_residual`), and at each dof the complementarity functions
        (Pa) times its lumped weight D_a (m), the force scale of the dof's rows in
        :meth:`residual_norm` (all processes)."""
        lo, hi = f.getOwnershipRange()
        g = self.indices[:, self._nh:]
        own = np.concatenate([self.slot, self.fslot], axis=1) & (g >= lo) & (g < hi)
        rows = np.unique(g[own]) - lo
        a = f.getArray(readonly=True)
        cn, ct = self._merit_rows
        once, fonce = self._once, self._tile(self._once)
        total = (float(np.dot(a, a)) - float(np.dot(a[rows], a[rows]))
                 + float(np.sum((self._D * cn)[once] ** 2))
                 + float(np.sum((self._tile(self._D) * ct)[fonce] ** 2)))
        return float(np.sqrt(max(self._mpi.allreduce(total), 0.0)))

    def stall(self) -> None:
        """The line search's merit function has stalled: the guard (module documentation),
        the threshold fixed point for the rest of the load step."""
        self.guarded = True
        self.guards += 1
        self._flips[:] = 0

    @property
    def _direction_in_newton(self) -> bool:
        """3-D with Coulomb's law in Newton: the slip direction p = q / |q| of a slipping dof
        is a function of the iterate whose derivative is in the tangent
        (:meth:`_direction_coupling`), not a status; the statuses are which dofs slip.  So
        after the guard too (the bound frozen: a Tresca problem, whose Newton converges
        quadratically with the direction in its tangent and linearly, over the threshold
        iterations, with the direction a status: measured on the sphere under partial slip,
        bench/contact3d_sphere.py's case, N = 6, mu = 0.05 ... 0.3: 9 of 10 runs converged
        against 6 of 10)."""
        return self._nf > 1 and self.coulomb_newton and not (self.unbounded or self.free_start)

    def _threshold_update(self):
        return ThresholdUpdate(
            lambda a, b: self._mpi.allreduce(float((a[self._once] * b[self._once]).sum())))

    # -- set-up ---------------------------------------------------------------------
    def _kinematics(self, el, pts):
        """Per vertex row of every element: its linear function at the Gauss points,
        and the shares of the weighted gap and slip operators (batched)."""
        op = self._op
        w = pts.w
        self._lin = el.shape_linear(pts.xi)                                     # (k, q, nv)
        a_n = op.normal_operator()                                              # (k, q, d nn)
        self._An = np.einsum("kq,kqv,kqd->kvd", w, self._lin, a_n)              # (k, nv, d nn), m
        self._At = [np.einsum("kq,kqv,kqd->kvd", w, self._lin, a_t) for a_t in op.tangential_operators()]
        self._Wv = np.einsum("kq,kqv->kv", w, self._lin)                        # (k, nv), m

    def _dependent_vertices(self):
        """Rows (element, vertex) whose value extrapolates dofs with a negative weight,
        numbered over every process by their vertex's input id."""
        dep = (self.space.T < NEGATIVE).any(axis=2)                              # (k, nv)
        vid = self.space.topo.verts
        ids = np.unique(np.concatenate(self._mpi.allgather(vid[dep])))
        self.n_dep = len(ids)
        self._dep = dep
        self._dep_index = np.where(dep, np.searchsorted(ids, np.where(dep, vid, ids[0] if len(ids) else 0)), -1)

    def _positive_weights(self, in_play: BoolArray | None = None) -> None:
        """Make the dofs' lumped weights D_a positive: the dependent vertices whose negative
        weights give a dof D_a <= 0 take their convex combination for good
        (``self.held_convex``), until no such dof is left.  ``in_play`` None (set-up): weak
        vertices, every dof; a mask ``(k, m)`` of the dofs whose statuses are in play (the
        sticking start breaks the law there, or a status iteration changed their contact
        status): gradient ties too, for those dofs.

        The equilibrium pairs LAGS_C_a with the weighted gap G_a = int phi_a [u].n, and the
        conditions hold on the mean gap g_a = G_a / D_a: with D_a < 0 they ask for G_a <= 0
        with LAGS_C_a <= 0, the conditions of no minimisation problem, and the status loop
        cycled between a dof in tension and the same dof interpenetrating (measured on the
        floating inclusions of bench/inclusion_family.py: TRIA6 24 x 24, R = 2.1 m, D = -3.7e-3
        and -1.4e-3 where the median is 0.26, from weak vertices: 7 forced status loops and a
        dof in tension at 0.46 of the pressure scale; QUAD8 40 x 40, R = 2.45 m, -3.4e-2 from
        gradient ties: 4 forced loops).  The convex combination has no negative weight, so
        such a vertex adds to D_a; it keeps constants exact, linear fields where the vertex lies
        in its roots' hull.  A gradient tie's convex form is a merge, which costs the exactness
        of linear fields along a flat stretch (cases/validation/flat_arc.toml: LAGS_C 1e-8 ->
        1.2e-6; the arc sweep of tests/test_stability.py 1.5e-5 for its 1e-5), so it is switched
        only for a dof in play, which a sticking dof never is.  Measured: the inclusions whose
        dofs of negative weight cycled break the law there at the sticking start (tension, or
        |T| above the bound); the one dof of negative weight of low_friction on 160 x 160
        sticks at the bottom of the arc, and its tie, merged, cost 22 -> 76 Newton iterations
        from the sticking start."""
        if not self.n_dep:
            return
        if in_play is None:
            kept = np.isin(self.space.topo.verts, self.space.gradient_tied)      # (k, nv)
            bad_dofs = self.slot
        else:
            kept, bad_dofs = np.zeros(self._dep.shape, bool), self.slot & in_play
        while True:
            bad = bad_dofs & (self._D <= 0.0)
            rows = self._dep & ((self.space.T < NEGATIVE) & bad[:, None, :]).any(axis=2) & ~kept
            mark = np.zeros(self.n_dep, bool)
            mark[self._dep_index[rows]] = True
            mark = np.logical_or.reduce(self._mpi.allgather(mark)) & ~self.held_convex
            if not mark.any():
                return
            self.held_convex |= mark
            self.extrapolated &= ~mark
            self._functions()

    def _functions(self):
        """The vertex map ``T (k, nv, m)`` of the current modes of the dependent vertices,
        and the weighted gap and slip operators ``(k, m, 2nn)`` and weights ``(k, m)``
        of the dofs (element shares and assembled)."""
        convex = self._dep & ~(self.extrapolated[np.maximum(self._dep_index, 0)] if self.n_dep else True)
        self._Tv = np.where(convex[:, :, None], self.space.T_convex, self.space.T)
        self._Bn = np.einsum("kvm,kvd->kmd", self._Tv, self._An)
        self._Bt = np.concatenate([np.einsum("kvm,kvd->kmd", self._Tv, At) for At in self._At], axis=1)
        self._Dk = np.einsum("kvm,kv->km", self._Tv, self._Wv)
        self._DkT = self._tile(self._Dk)
        self._D = self._assembled(self._Dk, self._DkT)[0]
        self.equations_changed = True

    # -- friction components ----------------------------------------------------------
    def _tile(self, a):
        """A per-dof array ``(k, m)`` repeated for every friction component ``(k, nf m)``
        (the friction slots: component c of slot j at column c m + j)."""
        return np.tile(a, (1, self._nf))

    def _sliding(self, slip):
        """Friction slots ``(k, nf m)`` of the dofs that slip (2-D: p = +-1; 3-D: a
        non-zero direction, every component of the dof)."""
        if self._nf == 1:
            return slip != 0
        return self._tile(self._fold(slip != 0))

    def _fold(self, a):
        """A boolean per-friction-slot array ``(k, nf m)`` reduced to the dofs ``(k, m)``
        (any component)."""
        if self._nf == 1:
            return a
        return a.reshape(a.shape[0], self._nf, self._m).any(axis=1)

    # -- assembly of dof and dependent-vertex sums ----------------------------------
    def _assembled(self, share_c, share_f):
        """Sum over elements of per-slot shares ``(k, m)`` and ``(k, nf m)`` (LAGS_C and
        friction slots):
        the dof values, back at every slot."""
        y, g = self._y, self.indices
        nh, m = self._nh, self._m
        y.set(0.0)
        live, live_f = self.slot, self.fslot
        idx = np.r_[g[:, nh:nh + m][live], g[:, nh + m:][live_f]].astype(PETSc.IntType)
        if len(idx):
            y.setValues(idx, np.r_[share_c[live], share_f[live_f]], addv=PETSc.InsertMode.ADD_VALUES)
        y.assemblyBegin()
        y.assemblyEnd()
        ve = self._op.element_values(y)
        return ve[:, nh:nh + m], ve[:, nh + m:]

    def _dep_value(self, rows):
        """One value per dependent vertex from per-row values ``(k, nv)`` that agree to
        round-off (the smallest, so that every process gets the same)."""
        out = np.full(self.n_dep, np.inf)
        np.minimum.at(out, self._dep_index[self._dep], rows[self._dep])
        if self.n_dep and self._mpi.size > 1:
            self._mpi.Allreduce(MPI.IN_PLACE, out, op=MPI.MIN)
        return out

    def _mean_divisor(self):
        """The lumped weights D_a ``(k, m)`` that turn the weighted gap and slip into
        mean ones (1 on empty slots).  Positive wherever statuses are in play
        (:meth:`_positive_weights`); a sticking case may keep a gradient tie's negative
        D_a, whose mean keeps its sign (a constant jump has that constant as mean)."""
        return np.where(self.slot & (self._D != 0), self._D, 1.0)

    def _max(self, a):
        return self._mpi.allreduce(float(np.abs(a).max(initial=0.0)), op=MPI.MAX)

    def _lam_scale(self, lam):
        """The pressure scale: max |LAGS_C| now, and after the first load step at least
        the largest of the previous steps."""
        return max(self._max(lam), self._floor_lam)

    def _lam_zero(self, lam):
        """Pressures at most this (Pa) are zero in the status and threshold tests: the
        round-off of max |LAGS_C| now, and after the first load step HISTORY_ZERO times
        the largest pressure of the previous steps (a load back to zero leaves
        pressures of the round-off of the earlier ones, amplified by the conditioning:
        statuses, thresholds and the ratio LAGS_F1 must not follow them)."""
        return max(nodal.ROUNDOFF * self._max(lam), HISTORY_ZERO * self._floor_lam)

    def _threshold(self, lam):
        """Thresholds s = min(LAGS_C, 0), zero where |LAGS_C| <= :meth:`_lam_zero`."""
        if self._floor_lam == 0.0:
            return nodal.threshold(lam, self._max(lam))
        s = np.minimum(lam, 0.0)
        return np.where(np.abs(s) <= self._lam_zero(lam), 0.0, s)

    def _gap_scale(self, h):
        """The scale (m) of the mean gaps: over the vertex rows whose weight is not
        round-off (an interface along cell faces gives the cell's other vertices
        weights of 1e-17, whose ratios would set the scale near 1e280 and hide every
        interpenetration from the status test)."""
        Wv = np.abs(self._Wv)
        live = Wv > nodal.ROUNDOFF * self._max(Wv)
        ratio = np.einsum("kvd,kd->kv", np.abs(self._An), np.abs(h)) / np.where(live, Wv, 1.0)
        return self._max(np.where(live, ratio, 0.0))

    # -- cycles ---------------------------------------------------------------------
    def _fingerprint(self, values):
        """A number that identifies the statuses ``values (k, m)`` (or friction slots
        ``(k, nf m)``) of every dof."""
        if values.shape[1] != self._m:
            values = np.einsum("kmc,c->km", self._split(values), 1.0 + np.arange(self._nf))
        return round(self._mpi.allreduce(float(((values + 2.0) * self._mark)[self._once].sum())), 9)

    def _first_change(self, changed):
        """``changed (k, m)`` reduced to the dof of least input id (all processes);
        friction slots ``(k, nf m)``: every component of that dof."""
        if changed.shape[1] != self._m:
            return self._tile(self._first_change(self._fold(changed)))
        ids = np.where(changed & self.slot, self._dof_id, np.iinfo(np.int64).max)
        least = self._mpi.allreduce(int(ids.min(initial=np.iinfo(np.int64).max)), op=MPI.MIN)
        return changed & (self._dof_id == least)

    def _no_cycle(self, old, new, seen, degenerate=None):
        """``new`` statuses, or -- when they were met before since ``seen`` was cleared
        (active sets cycle where the Schur complement is no M-matrix) -- ``old`` with
        only the change of least dof id (Murty's least-index rule, which ends for
        positive definite problems).  ``degenerate (k, m)``: dofs whose change in a
        cycle is left out (both of their statuses solve the problem to
        :data:`DEGENERATE`; round-off, amplified by the conditioning, decides
        between them and would flip them forever)."""
        if self._fingerprint(new) in seen:
            if degenerate is not None:
                new = np.where(degenerate, old, new)
            one = self._first_change(self._changed(new, old))
            new = np.where(one, new, old)
        return new

    def _changed(self, new, old, tol=DIRECTION_CHANGE):
        """Where statuses differ: contact and 2-D friction statuses exactly; 3-D slip
        directions (friction slots) by more than ``tol`` in a component (every component
        of such a dof; with the direction in Newton, where a dof starts or stops slipping)."""
        if new.shape[1] == self._m or self._nf == 1:
            return new != old
        if self._direction_in_newton:         # the directions are no statuses: which dofs slip
            return self._tile(self._fold(new != 0) != self._fold(old != 0))
        return self._moved(new, old, tol)

    def _moved(self, new, old, tol):
        """3-D: friction slots of the dofs whose slip directions ``new``, ``old`` differ by
        more than ``tol`` in a component (one that starts or stops slipping by at least
        1 / sqrt 2)."""
        return self._tile(self._fold(np.abs(new - old) > tol))

    # -- state at x -----------------------------------------------------------------
    def _values(self, x):
        """Element values and the dof and vertex fields at ``x``."""
        ve = self._op.element_values(x)
        nh, m = self._nh, self._m
        h, lam, T = ve[:, :nh], ve[:, nh:nh + m], ve[:, nh + m:]
        return ve, h, lam, T

    def _fbounds(self):
        """:meth:`_bounds` at the friction slots ``(k, nf m)``."""
        on, bound = self._bounds()
        return self._tile(on), self._tile(bound)

    def _bounds(self):
        """Friction active at the dofs ``(k, m)`` and their bound mu |s| (Pa; inf unbounded)."""
        on = (self.chi == 1) & self.slot & self.friction
        if self.unbounded:
            return on, np.full(self.s.shape, np.inf)
        s = self._newton_s if (self._newton_s is not None and self.merit_active) else self.s
        bound = self.mu * np.abs(s)
        return on & (bound > 0), bound

    def _friction_statuses(self, x):
        """The friction statuses the rules give at ``x`` from the committed ones, and
        the values they come from: ``(slip, h, lam, T, gt, active, bound)`` (``gt`` the
        step's mean slips, m)."""
        ve, h, lam, T = self._values(x)
        if self._in_newton and self.friction:
            # Coulomb in Newton: the bound is mu |LAGS_C| of this iterate (and s follows
            # LAGS_C, so that the threshold loop and the results see the bound used)
            self.s = np.where(self.slot, self._threshold(lam), 0.0)
            self._newton_s = (np.where(self.slot, self._threshold(self._augmented_pressure(h, lam)), 0.0)
                              if self.merit_active else None)
        active, bound = self._fbounds()
        gt = self._mean_slip(h if self._h0 is None else h - self._h0, lam.shape)
        # the round-off of the slips: on the scale of the slip (of the step, and after
        # the first step of the whole slip as well), and at least on that of the elastic
        # displacement the bounds cause over a cell (bound h / E: where slip starts, at a
        # stick/slip limit reached exactly, the slips are round-off themselves)
        scale = max(self._max(np.where(active, gt, 0.0)),
                    self._max(np.where(active & np.isfinite(bound), bound, 0.0)) / self._kappa)
        if self._h0 is not None:
            scale = max(scale, self._max(np.where(active, self._mean_slip(h, lam.shape), 0.0)))
        if self._nf == 1 and self.merit_active:
            status = nodal.friction_status_augmented(self.slip, active, T, gt, bound, NEWTON_SCALE * self._kappa,
                                                     nodal.ROUNDOFF * scale)
        elif self._nf == 1:
            status = nodal.friction_status(self.slip, active, T, gt, bound, STATUS_SCALE * self._kappa,
                                           nodal.ROUNDOFF * scale)
        else:
            status = self._components(nodal.friction_direction(
                self._split(self.slip), active[:, :self._m], self._split(T), self._split(gt),
                bound[:, :self._m], STATUS_SCALE * self._kappa, nodal.ROUNDOFF * scale,
                DIRECTION_SCALE * self._kappa if self._direction_in_newton else None))
        if not self._direction_in_newton and not self._in_newton:
            # (with Coulomb in Newton a held status would end in a state that is no
            # solution; the cycle guard handles chattering there)
            status = np.where(self._flips >= MAX_FLIPS, self.slip, status)
        if self._nf > 1 and not self._direction_in_newton:
            # a direction that moved by round-off only is the same status (in Newton the
            # direction is the trial traction's at x, exactly: the residual is then the
            # function the tangent differentiates)
            status = np.where(self._changed(status, self.slip), status, self.slip)
        if not self._direction_in_newton and not self._in_newton:   # (else the cycle guard of _terms)
            status = self._no_cycle(self.slip, status, self._seen_slip)
        return status, h, lam, T, gt, active, bound

    def _augmented_pressure(self, h, lam):
        """With the line search (:attr:`merit_active`), the pressures whose negative part bounds
        friction in Newton, at the dofs ``(k, m)`` (Pa): Alart and Curnier's augmented
        lam + r gn (r = NEWTON_SCALE E / h, the bound of :func:`nodal.complementarity`; at a
        solution LAGS_C where the dof is in contact).
        Measured (Newton iterations over the run with mu |LAGS_C| / with the augmented bound):
        arc under shear QUAD8 18 / 15, on Gmsh quadrangles 23 / 15, inclusion TRIA6 20 / 10 and
        QUAD8 462 / 93 (4 status loops forced / none), SSNV509 mu = 0.2 QUAD8 14 / 13, Gmsh TRIA6
        11 / 9, cases/validation/history_open_reclose.toml 40 / 15: a dof that closes has lam =
        0 at the iterate, hence no friction with mu |LAGS_C|, and slid a whole step before
        its pressure came, then reversed."""
        return lam + NEWTON_SCALE * self._kappa * self._gap_and_tolerances(h, lam)[0]

    def _mean_slip(self, h, shape):
        """Mean slips ``gt (k, m)`` (m) at the dofs of the jump dofs ``h``."""
        return (self._assembled(np.zeros(shape), np.einsum("kmd,kd->km", self._Bt, h))[1]
                / self._tile(self._mean_divisor()))

    def _split(self, a):
        """``(k, nf m)`` friction-slot values as vectors ``(k, m, nf)`` in the tangent basis."""
        return a.reshape(a.shape[0], self._nf, self._m).transpose(0, 2, 1)

    def _components(self, v):
        """Vectors ``(k, m, nf)`` back to friction slots ``(k, nf m)``."""
        return v.transpose(0, 2, 1).reshape(v.shape[0], self._nf * self._m)

    def _statuses(self, x, commit):
        """The contact and friction statuses for the terms at ``x`` and the values they
        come from: ``(chi, slip, h, lam, T, gt, active, bound)``.  With Coulomb's law in
        Newton the contact statuses are those of the rules at ``x`` too, unless Newton
        has had them before in this threshold iteration (the cycle guard: the committed
        contact statuses and the bound frozen from here on, for good with ``commit``).
        ``self.chi`` is left as committed (``commit``: as found)."""
        committed = self.chi
        if self._in_newton:
            self.chi = self._contact_at(x)
        try:
            slip, h, lam, T, gt, active, bound = self._friction_statuses(x)
            if self._in_newton and not self.line_search and self._cycled(committed, slip):
                self.chi = committed
                if commit:
                    self.guarded = True
                    self.guards += 1
                    self._flips[:] = 0
                self._guard_now = True
                try:
                    slip, h, lam, T, gt, active, bound = self._friction_statuses(x)
                finally:
                    self._guard_now = False
            chi = self.chi
        finally:
            if not commit:
                self.chi = committed
        return chi, slip, h, lam, T, gt, active, bound

    def _state_key(self, chi, slip):
        """Newton's statuses ``chi``, ``slip`` as a key of the cycle guard (3-D: which dofs
        slip, the directions being functions of the iterate)."""
        if self._nf > 1:
            slip = np.where(self._sliding(slip), 1.0, 0.0)
        return self._fingerprint(chi), self._fingerprint(slip)

    def _remember_state(self, chi, slip):
        """Add Newton's statuses ``chi``, ``slip`` to those met in this threshold iteration."""
        seen = self._seen_states.setdefault(self._state_key(chi, slip), [])
        if self._nf > 1:
            seen.append(np.where(self._sliding(slip), slip, 0.0))

    def _cycled(self, committed, slip):
        """Whether Newton meets again, with ``self.chi`` and ``slip``, statuses it has had in
        this threshold iteration (the committed ones ``committed``, ``self.slip`` are added
        to them at each tangent).  In 3-D staying in the committed statuses is no cycle:
        with the direction in the tangent, Newton takes several iterations in the same
        statuses (in 2-D, where the problem is linear for given statuses, that is a
        converged Newton and the rule is kept as it was); and statuses met before are a
        cycle only with the directions they had then, to DIRECTION_CYCLE."""
        key = self._state_key(self.chi, slip)
        if key not in self._seen_states:
            return False
        if self._nf == 1:
            return True
        if key == self._state_key(committed, self.slip):
            return False
        now = np.where(self._sliding(slip), slip, 0.0)
        return any(self._max(now - before) <= DIRECTION_CYCLE for before in self._seen_states[key])

    def _terms(self, x, commit=False):
        """Everything the residual and the tangent need at ``x``: ``(h, terms, slipping,
        trial, bound)`` (``slipping``: the friction slots whose bound -mu LAGS_C is in
        Newton, None without; ``trial``: the tractions T + r gt whose directions are the
        slip directions in Newton (3-D; r = DIRECTION_SCALE E/h), Pa, and ``bound``
        the bounds mu |s| of the friction slots).  With ``commit`` the statuses found at
        ``x`` become the committed ones."""
        committed = self.chi
        in_newton = self._in_newton
        chi, slip, h, lam, T, gt, active, bound = self._statuses(x, commit)
        if commit:
            if in_newton:
                self._remember_state(committed, self.slip)
            self._seen_slip.add(self._fingerprint(self.slip))
            self._flips += self._changed(slip, self.slip)
            self.slip = slip
            if in_newton and not self.line_search and \
                    self._mpi.allreduce(bool((self._flips >= CHATTER_FLIPS).any()), op=MPI.LOR):
                self.guarded = True           # a dof chatters: the guard (module documentation)
                self.guards += 1
                self._flips[:] = 0
        rho_T = self.rho_T if self.rho_T is not None else self.rho_n
        slipping = None
        if (self._in_newton or self._direction_in_newton) and self.friction:
            slipping = active & self._sliding(slip) & (bound > 0)
        # 3-D in Newton: the equilibrium holds a slipping dof's own T (_direction_coupling)
        carried = slipping if (self._direction_in_newton or self.merit_active) else None
        t = nodal.terms(chi, slip, active, lam, T, bound, self._Dk, self.rho_n, rho_T, self._DkT,
                        None if self._nf == 1 else self._sliding(slip), carried)
        return h, t, slipping, T + DIRECTION_SCALE * self._kappa * gt, bound

    # -- Newton ---------------------------------------------------------------------
    def add_residual(self, x: PETSc.Vec, f: PETSc.Vec) -> None:
        h, t = self._terms(x)[:2]
        Bn, Bt = self._Bn, self._Bt
        Rh = np.einsum("km,kmd->kd", t["cn"], Bn) + np.einsum("km,kmd->kd", t["ct"], Bt)
        Rl = t["wn"] * np.einsum("kmd,kd->km", Bn, h) + t["rl"]
        ht = h if self._h0 is None else h - self._h0          # friction: the step's increment
        RT = t["wt"] * np.einsum("kmd,kd->km", Bt, ht) + t["rT"]
        R = np.concatenate([Rh, Rl, RT], axis=1)
        live = self.indices >= 0
        f.setValues(self.indices[live].astype(PETSc.IntType), R[live], addv=PETSc.InsertMode.ADD_VALUES)
        f.assemblyBegin()
        f.assemblyEnd()

    def tangent(self, x: PETSc.Vec) -> FloatArray:
        """Element tangents ``(k, nd, nd)``: the symmetric part of the tangent (with
        Coulomb's law in Newton, the coupling of the slipping dofs' traction to their
        pressure is :meth:`coupling`); commits the statuses of ``x``."""
        h, t, slipping, trial, bound = self._terms(x, commit=True)
        Bt = self._Bt
        k, nd = self.indices.shape
        nh, m = self._nh, self._m
        K = np.zeros((k, nd, nd))
        Kn = self._Bn * t["wn"][:, :, None]                      # (k, m, 2nn)
        # 2-D with the line search, the equilibrium holds a slipping dof's own T: its column
        # Bt^T, and the transpose in its row, go into the symmetric part (its row's own
        # derivative is -Bt plus the bound's: :meth:`_augmented_coupling`), so that the
        # symmetric part stays a good preconditioner of the whole (a user's Krylov method)
        held = t["wt"] + (slipping if (self.merit_active and slipping is not None) else 0.0)
        Kt = Bt * held[:, :, None]
        K[:, nh:nh + m, :nh] = Kn
        K[:, :nh, nh:nh + m] = Kn.transpose(0, 2, 1)
        K[:, nh + m:, :nh] = Kt
        K[:, :nh, nh + m:] = Kt.transpose(0, 2, 1)
        i = np.arange(m)
        K[:, nh + i, nh + i] = t["kl"]
        j = np.arange(self._nf * m)
        K[:, nh + m + j, nh + m + j] = t["kT"]
        self._coupling = (self._direction_coupling(slipping, trial, bound) if self._direction_in_newton
                          else self._augmented_coupling(slipping) if self.merit_active
                          else self._coupling_terms(slipping))
        return K

    def _coupling_terms(self, slipping):
        """Element matrices ``(k, nd, nd)`` of the derivative of the slipping dofs' terms
        with respect to their pressure (None: nothing slips with the bound in Newton).

        A slipping friction slot j (dof a) carries the traction f_j = -mu lam_a p_j in the
        equilibrium (rows of the jump dofs: f_j times the slot's slip operator) and its
        row is D_j (T_j - f_j) / rho_T: d/d lam_a gives -mu p_j Bt_j and mu p_j D_j / rho_T."""
        if slipping is None or not self._mpi.allreduce(bool(slipping.any()), op=MPI.LOR):
            return None
        nh, m = self._nh, self._m
        k, nd = self.indices.shape
        rho_T = self.rho_T if self.rho_T is not None else self.rho_n
        dfix = np.where(slipping, -self.mu * self.slip, 0.0)                    # (k, nf m)
        C = np.zeros((k, nd, nd))
        j = np.arange(self._nf * m)
        lam_col = nh + j % m
        # jump rows: the components' dfix_j Bt_j summed into the column of their dof's lam_a
        nf = self._nf
        C[:, :nh, nh:nh + m] = np.einsum("kcm,kcmd->kdm", dfix.reshape(k, nf, m),
                                         self._Bt.reshape(k, nf, m, nh))
        C[:, nh + m + j, lam_col] = -self._DkT * dfix / rho_T
        return C

    def _augmented_coupling(self, slipping):
        """2-D with the line search: element matrices ``(k, nd, nd)`` of the non-symmetric part
        of the tangent (None: nothing slips).  A slipping dof a carries f = b p, b = -mu q_a,
        q_a = lam_a + r gn_a (r = NEWTON_SCALE E / h, gn_a = sum_e Bn^e_a h_e / divisor_a its
        mean gap); the equilibrium holds T_a itself (``carried``, as in
        :meth:`_direction_coupling`) and its row is D_a (T_a - f) / rho_T, so that every
        derivative stays in an element's block.  The symmetric part (:meth:`tangent`) holds
        the column Bt^e_j of T_j in the rows of the jump dofs and, for symmetry, Bt^e_j in
        the row of T_j; the rest of that row's derivative is here:

        * row T_j, column lam_a: D^e_a mu p / rho_T;
        * row T_j, jump dofs of e: mu p r Bn^e_a / rho_T times D_a over the divisor (1 where
          D_a != 0), whose sum over the elements is D_a mu p r dgn_a / rho_T, minus the
          symmetric part's Bt^e_j."""
        if slipping is None or not self._mpi.allreduce(bool(slipping.any()), op=MPI.LOR):
            return None
        nh, m = self._nh, self._m
        k, nd = self.indices.shape
        rho_T = self.rho_T if self.rho_T is not None else self.rho_n
        p = np.where(slipping, self.slip, 0.0)                                   # (k, m)
        C = np.zeros((k, nd, nd))
        j = np.arange(m)
        C[:, nh + m + j, nh + j] = self._Dk / rho_T * self.mu * p
        mean = self._D / self._mean_divisor()
        r = NEWTON_SCALE * self._kappa
        C[:, nh + m:, :nh] = ((self.mu * r / rho_T) * (p * mean)[:, :, None] * self._Bn
                              - self._Bt * slipping[:, :, None])
        return C

    def _direction_coupling(self, slipping, trial, bound):
        """3-D: element matrices ``(k, nd, nd)`` of the non-symmetric part of the tangent,
        the derivative of the slipping dofs' terms (None: nothing slips with its bound in
        Newton).  ``slipping`` ``(k, nf m)``, ``trial`` (Pa) and ``bound`` (Pa): the friction
        slots of :meth:`_terms`.

        A slipping dof a carries f = b p (Pa, in the tangent basis), b = -mu lam_a its bound,
        p = q / |q|, q = T_a + r gt_a (r = DIRECTION_SCALE E/h, gt_a =
        sum_e Bt_e (h_e - h0_e) / D_a its mean slip in the step: the slip operators of every
        element around the dof).  Its rows are R_a = D_a (T_a - f) / rho_T, and the
        equilibrium holds T_a itself (Bt_j T_j in the rows of the jump dofs: ``carried`` of
        :func:`nodal.terms`), so that every derivative stays in an element's block: with f in
        the equilibrium, df / dgt_a would couple the jump dofs of elements that share only
        the dof.  At a solution T_a = f, as with f in the equilibrium; both give the same
        Newton step (substitute the linearised row, df = dT_a + T_a - f, into the
        equilibrium's).  With A = df/dq = b (I - p p^T) / |q| (:func:`nodal.direction_derivative`),
        df = A dT_a - mu p dlam_a + r A dgt_a, hence in element e, for the components c, c' of
        the slot j of dof a (D^e_a the element's share of D_a, the symmetric tangent holding
        D^e_a / rho_T on the diagonal of the slipping rows):

        * rows of the jump dofs, column T_jc: Bt^e_jc;
        * row T_jc, column T_jc': -D^e_a A_cc' / rho_T;
        * row T_jc, column lam_a: D^e_a mu p_c / rho_T;
        * row T_jc, jump dofs of e: -r sum_c' A_cc' Bt^e_jc' / rho_T (times D_a over the mean's
          divisor, 1 where D_a != 0), whose sum over the elements is -D_a r A dgt_a / rho_T.
        """
        if slipping is None or not self._mpi.allreduce(bool(slipping.any()), op=MPI.LOR):
            return None
        nh, m, nf = self._nh, self._m, self._nf
        k, nd = self.indices.shape
        rho_T = self.rho_T if self.rho_T is not None else self.rho_n
        on = self._fold(slipping)                                                # (k, m)
        b = np.where(on, bound[:, :m], 0.0)
        A = nodal.direction_derivative(self._split(trial), b) * on[:, :, None, None]   # (k, m, nf, nf)
        p = np.where(on[:, :, None], self._split(self.slip), 0.0)                 # (k, m, nf)
        Bt = self._Bt.reshape(k, nf, m, nh)                                      # (k, c, m, 2nn)
        C = np.zeros((k, nd, nd))
        C[:, :nh, nh + m:] = (self._Bt * slipping[:, :, None]).transpose(0, 2, 1)
        j, c, c2 = np.meshgrid(np.arange(m), np.arange(nf), np.arange(nf), indexing="ij")   # (m, nf, nf)
        share = self._Dk / rho_T                                                 # (k, m)
        C[:, nh + m + c * m + j, nh + m + c2 * m + j] = -share[:, :, None, None] * A
        if self._in_newton:                      # the bound -mu LAGS_C (frozen after the guard)
            C[:, nh + m + c[..., 0] * m + j[..., 0], nh + j[..., 0]] = share[:, :, None] * self.mu * p
        mean = self._D / self._mean_divisor()                                    # D_a / divisor: 1 or 0
        rows = np.einsum("kmce,kemd->kcmd", A, Bt).reshape(k, nf * m, nh)
        C[:, nh + m:, :nh] = -(DIRECTION_SCALE * self._kappa / rho_T) * self._tile(mean)[:, :, None] * rows
        return C

    def coupling(self) -> FloatArray | None:
        """The non-symmetric part of the last tangent, element matrices ``(k, nd, nd)``
        (None: none, the tangent is symmetric).  With Coulomb's law in Newton the bound
        of a slipping dof is -mu LAGS_C: its derivative (:meth:`_coupling_terms`)."""
        return self._coupling

    def residual_norm(self, F: PETSc.Vec) -> float:
        """The norm of the residual ``F`` with the rows of the multiplier dofs weighed into
        forces (N/m) like the rows of the displacements: a weighted gap or slip row (m^2)
        by E / h, the row of an inactive or slipping dof (its value over rho, m^2) by its
        rho (all processes).  Without the weights, a gap or slip row violated by a whole
        interpenetration or slip increment is negligible against the loads, and Newton
        stops before solving it; with E / h on every row, a small COEF_FROT made the rows of
        slipping dofs weigh kappa / rho_T times their forces and Newton chase round-off."""
        lo, hi = F.getOwnershipRange()
        if self._kappa_rows is None:
            g = self.indices[:, self._nh:]
            own = np.concatenate([self.slot, self.fslot], axis=1) & (g >= lo) & (g < hi)
            self._kappa_rows = np.flatnonzero(own)          # owned multiplier slots, flat (k, 2m)
        a = F.getArray(readonly=True)
        total = float(np.dot(a, a))
        g = self.indices[:, self._nh:].ravel()[self._kappa_rows] - lo
        rows, first = np.unique(g, return_index=True)
        w = self._row_weights().ravel()[self._kappa_rows][first]
        kin = float(np.dot(a[rows], a[rows]))
        weighed = float(np.dot(w * a[rows], w * a[rows]))
        total, kin, weighed = self._mpi.allreduce(np.array([total, kin, weighed]))
        return float(np.sqrt(max(total - kin + weighed, 0.0)))

    def _row_weights(self) -> FloatArray:
        """``(k, 2m)``: the force scale (Pa/m) of the rows of the LAGS_C and LAGS_F1 slots
        (see :meth:`residual_norm`), from the committed statuses."""
        rho_T = self.rho_T if self.rho_T is not None else self.rho_n
        active, _ = self._fbounds()
        wc = np.where(self.chi == 1, self._kappa, self.rho_n)
        wf = np.where(active & ~self._sliding(self.slip), self._kappa, rho_T)
        return np.concatenate([wc, wf], axis=1)

    def friction_settled(self, x: PETSc.Vec, tol: float = 0.0) -> bool:
        """Whether the friction statuses at ``x`` are those its Jacobian used (all
        processes).  The rows of the conditions are kinematic (m^2): a Newton iterate
        whose statuses are still changing can have a residual far below the loads'
        (a stick row violated by a whole slip increment weighs D |slip|), so Newton's
        convergence also asks for settled statuses (a semi-smooth Newton converges when
        its active set stops changing).  In 3-D, also asks for slip directions within
        DIRECTION_SETTLED of its Jacobian's (with the direction in Newton, a step in the
        directions that small ends a quadratic convergence: the iterate is then accurate
        to round-off, where the residual test alone may stop one iteration earlier).
        ``tol`` (N/m): Newton's tolerance on the residual norm; 2-D, friction statuses that
        change where both branches hold within it do not count (:meth:`_within_tolerance`)."""
        contact = self._in_newton and bool(np.any((self._contact_at(x) != self.chi) & self.slot))
        if not self.friction:
            return not self._mpi.allreduce(contact, op=MPI.LOR)
        committed = self.chi
        if self._in_newton:
            self.chi = self._contact_at(x)
        try:
            slip, h, lam, T, gt, active, bound = self._friction_statuses(x)
        finally:
            self.chi = committed
        settled = DIRECTION_SETTLED if self._in_newton else GUARDED_DIRECTION_SETTLED
        changed = self._changed(slip, self.slip) if self._nf == 1 else self._moved(slip, self.slip, settled)
        changed &= self.fslot
        if self._nf == 1 and tol > 0.0:
            changed &= ~self._within_tolerance(changed, T, gt, active, bound, tol)
        return not self._mpi.allreduce(contact or bool(np.any(changed)), op=MPI.LOR)

    def _within_tolerance(self, changed, T, gt, active, bound, tol):
        """2-D: the friction slots among ``changed`` that sit on the kink of the law within
        Newton's tolerance ``tol`` (N/m): the stick row (the weighted slip, kappa D |gt|) and
        the slip row (D ||T| - mu |s||) both weigh at most ``tol`` in the residual norm, all of
        them together too (all processes; each dof once).  Either status then solves the
        discrete law as well as Newton's test asks.  Measured: cases/validation/low_friction.toml
        on 160 x 160 cells, 4 - 16 dofs with |T| = mu |LAGS_C| and slips of 5e-14 m (1.5e-7 of
        the largest) switched stick <-> slip at every iteration, the residual at 3e-14 of the
        loads, until ITER_GLOB_MAXI."""
        finite = active & np.isfinite(bound)
        D = self._tile(self._D)
        rows = np.maximum(self._kappa * np.abs(D * gt), np.abs(D * (np.abs(T) - np.where(finite, bound, 0.0))))
        near = changed & finite & (rows <= tol)
        mine = near & self._tile(self._once)
        total = self._mpi.allreduce(float(np.sum(rows[mine] ** 2)))
        return near if np.sqrt(total) <= tol else np.zeros_like(near)

    def add_matrices(self, J: PETSc.Mat, K: FloatArray) -> None:
        self._op.add_matrices(J, K)

    def add_product(self, K: FloatArray, x: PETSc.Vec, f: PETSc.Vec, scale: float = 1.0) -> None:
        self._op.add_product(K, x, f, scale)

    # -- outer loops ----------------------------------------------------------------
    def _count(self, changed):
        """Number of distinct dofs (all processes) among the slots ``changed``."""
        g = np.unique(self.indices[:, self._nh:self._nh + self._m][changed & self.slot])
        lo, hi = self._y.getOwnershipRange()
        return self._mpi.allreduce(int(((g >= lo) & (g < hi)).sum()))

    def update_status(self, x: PETSc.Vec) -> int:
        """Contact statuses of the dofs from ``x``, and the switch of dependent vertices
        whose extrapolated values are not admissible; returns the number of dofs and
        vertices that changed (all processes).  In the first threshold iteration
        without SEUIL_INIT (frictionless, or sticking if that has no equilibrium)
        the statuses stay as CONTACT_INIT set them: that linear solve only gives
        the first thresholds."""
        if self.unbounded or self.free_start:
            return 0
        ve, h, lam, T = self._values(x)
        gn, tol_lam, tol_gap = self._gap_and_tolerances(h, lam)
        new = np.where(self.slot, nodal.contact_status(self.chi, lam, gn, tol_lam, tol_gap), 0)
        if self.bilateral:                       # GLISSIERE: contact once made is kept
            new = np.maximum(new, self.chi)
        self._seen_contact.add(self._fingerprint(self.chi))
        weak = nodal.contact_status(self.chi, lam, gn, tol_lam * DEGENERATE / nodal.ROUNDOFF,
                                    tol_gap * DEGENERATE / nodal.ROUNDOFF) == self.chi
        new = self._no_cycle(self.chi, new, self._seen_contact, degenerate=weak)
        self._seen_slip.clear()
        self._seen_states.clear()
        changed = new != self.chi
        # friction statuses that x contradicts (a Newton solve that started converged,
        # after a threshold update, evaluated no tangent): they count as changes too
        slip = self._friction_statuses(x)[0] if self.friction else self.slip
        held = self._fold(self._changed(slip, self.slip))
        lam_eq, T_eq = self._equilibrium_tractions(lam, T)      # those x was solved with
        self.slip = np.where(self._tile(changed), 0.0, slip)       # a dof entering contact starts sticking
        self.chi = new
        count = self._count(changed | held)
        if count:
            self._positive_weights(in_play=changed)
        switched = self._admissible_vertices(lam_eq, T_eq, tol_lam)
        if switched:
            self._functions()
        self._settled = count + switched == 0
        return count + switched

    def _gap_and_tolerances(self, h, lam):
        """Mean gaps at the dofs ``(k, m)`` (m) and the round-off tolerances of the
        contact tests (Pa, m)."""
        D = self._mean_divisor()
        gn = self._assembled(np.einsum("kmd,kd->km", self._Bn, h), np.zeros(self.fslot.shape))[0] / D
        tol_lam = self._lam_zero(lam)
        tol_gap = nodal.ROUNDOFF * max(self._gap_scale(h), self._floor_gap)
        return gn, tol_lam, tol_gap

    def _contact_at(self, x):
        """The contact statuses the rules give at ``x`` from the committed ones
        (Coulomb's law in Newton: a semi-smooth Newton on contact too)."""
        ve, h, lam, T = self._values(x)
        gn, tol_lam, tol_gap = self._gap_and_tolerances(h, lam)
        if self.merit_active:                    # the augmented test (NEWTON_SCALE)
            rule = nodal.contact_status_augmented(self.chi, lam, gn, NEWTON_SCALE * self._kappa, tol_lam, tol_gap)
        else:
            rule = nodal.contact_status(self.chi, lam, gn, tol_lam, tol_gap)
        new = np.where(self.slot, rule, 0)
        return np.maximum(new, self.chi) if self.bilateral else new      # GLISSIERE: kept

    def _equilibrium_tractions(self, lam: FloatArray, T: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The dof tractions ``(lam, T)`` the equilibrium of the current statuses
        holds: 0 where not in contact, the bound mu |s| p where slipping.  (The dofs
        themselves hold these only to the accuracy of their rows, which rho_n and
        rho_T scale: far more than round-off when rho_T / D_a is large.)"""
        lam = np.where(self.chi == 1, lam, 0.0)
        if self.friction and not self.unbounded:
            active, bound = self._fbounds()
            T = np.where(active & self._sliding(self.slip), bound * self.slip, T)
        return lam, T

    def _inadmissible(self, lam: FloatArray, T: FloatArray, tol_lam: float) -> BoolArray:
        """``(n_dep,)`` whether the extrapolated values of each dependent vertex leave
        the admissible set (lam > 0, threshold > 0, |T| > mu |s|) for the dof
        tractions ``lam``, ``T`` (:meth:`_equilibrium_tractions`) and the current
        thresholds."""
        T_ext = self.space.T
        tension = np.inf if self.bilateral else tol_lam         # GLISSIERE: tension is admissible
        bad = self._dep_value(np.einsum("kvm,km->kv", T_ext, lam)) > tension
        if self.friction and not self.unbounded:
            active, bound = self._bounds()
            sw = self._dep_value(np.einsum("kvm,km->kv", T_ext, np.where(active, self.s, 0.0)))
            Tc = self._split(T)
            Tw = np.sqrt(sum(self._dep_value(np.einsum("kvm,km->kv", T_ext, np.where(active, Tc[..., c], 0.0))) ** 2
                             for c in range(self._nf))) if self._nf > 1 else \
                np.abs(self._dep_value(np.einsum("kvm,km->kv", T_ext, np.where(active, T, 0.0))))
            bad |= (sw > tol_lam) | (Tw > self.mu * np.abs(sw) * (1.0 + nodal.ROUNDOFF) + tol_lam * self.mu)
        return bad

    def _admissible_vertices(self, lam, T, tol_lam):
        """Switch the extrapolated dependent vertices whose values are not admissible
        to their convex combination; returns how many switched."""
        if not self.n_dep or not self.extrapolated.any():
            return 0
        bad = self._inadmissible(lam, T, tol_lam) & self.extrapolated
        self.extrapolated &= ~bad
        return int(bad.sum())

    def _restore_vertices(self, lam, T):
        """At a threshold update: dependent vertices switched to their convex
        combination go back to the extrapolation where it is admissible now, so that
        a switch made far from the solution does not outlive it."""
        back = ~self.extrapolated & ~self.held_convex & ~self._inadmissible(*self._equilibrium_tractions(lam, T),
                                                        self._lam_zero(lam))
        if back.any():
            self.extrapolated |= back
            self._functions()

    def wants_coarse_start(self, x: PETSc.Vec) -> bool:
        """2-D, Coulomb's law in Newton with the line search, the rich space (``algo_lagr``
        AUTO): the sticking start ``x`` breaks the law at a dof in contact (tension, or a
        tangential traction above mu |LAGS_C|), so the interface slides or opens, and Newton
        had better start from the solution in the stable space (:meth:`Model.coarse_start`;
        ``-xfc_coarse_start NONE``: from ``x``).  A start that satisfies the law (SSNV509:
        everything sticks) is already the answer and is kept."""
        if not self.unbounded:
            return False
        self._start_broken = self._broken_at(x)
        broken = bool(self._mpi.allreduce(bool(self._start_broken.any()), op=MPI.LOR))
        return (broken and self.line_search and self._nf == 1 and self.friction
                and self.space.algo in ("AUTO", "VERSION3")
                and options.get("coarse_start", "STABLE") == "STABLE")

    def _broken_at(self, x: PETSc.Vec) -> BoolArray:
        """``(k, m)``: the dofs in contact where ``x`` breaks the law: tension, or a tangential
        traction above mu |LAGS_C| (the same on every process: assembled values)."""
        ve, h, lam, T = self._values(x)
        tol = self._lam_zero(lam)
        on = self.slot & (self.chi == 1)
        bound = self.mu * np.maximum(-lam, 0.0) if self.friction else np.full(lam.shape, np.inf)
        Tn = np.abs(T) if self._nf == 1 else np.sqrt((self._split(T) ** 2).sum(axis=-1))
        return on & ((lam > tol) | (Tn > bound * (1.0 + nodal.ROUNDOFF) + self.mu * tol))

    def update_threshold(self, x: PETSc.Vec) -> BoolArray:
        """s <- LAGS_C at the dofs and dependent vertices (friction bounded from now on).
        Returns an empty mask: no stick predictor is needed."""
        if self.unbounded:                          # where the sticking start breaks the law
            broken = self._start_broken if self._start_broken is not None else self._broken_at(x)
            self._start_broken = None
            self._positive_weights(in_play=broken)
        ve, h, lam, T = self._values(x)
        self._seen_contact.clear()
        self._seen_slip.clear()
        self._seen_states.clear()
        self._flips[:] = 0
        target = np.where(self.slot, self._threshold(lam), 0.0)
        if self.guarded and self._settled and self._change(lam, target) <= REARM_CHANGE:
            self.guarded = False                  # Coulomb's law back into Newton (REARM_CHANGE)
            self.rearms += 1
        if self.unbounded or not np.any(self._mpi.allgather(bool(np.count_nonzero(self.s)))):
            self.s = target                            # the first thresholds
        else:
            # the statuses the acceleration's history is valid for (3-D: which dofs slip,
            # not their directions, which move by round-off from one solve to the next)
            slip = self.slip if self._nf == 1 else np.where(self._fold(self.slip != 0), 1.0, 0.0)
            key = (self._fingerprint(self.chi), self._fingerprint(slip), self.extrapolated.tobytes())
            self.s = self._accelerated(self.s, target, key)
        self.unbounded = self.free_start = False
        self._set_rho_T(self._max(self.s))
        if not self.extrapolated.all():
            self._restore_vertices(lam, T)
        return np.zeros(self.s.shape, bool)

    def _set_rho_T(self, pressure):
        """rho_T = mu COEF_FROT p (Pa/m), p the pressure scale of the first non-zero
        thresholds (COEF_CONT without COEF_FROT); fixed once set: it only scales the
        rows of slipping dofs, and a fixed value keeps the tangent of a converged
        state unchanged."""
        if self.rho_T is not None or not pressure:
            return
        if self._coef_frot is None:
            self.rho_T = self.rho_n
        else:
            self.rho_T = self._row_scale(self.mu * self._coef_frot * pressure, "coef_frot", "1/m",
                                         given=self._coef_frot)

    def _row_scale(self, rho, key, unit, given=None):
        """``rho`` (Pa/m), or the nearest bound of ROW_SCALES times E / h with a warning:
        the coefficients only scale rows, and beyond those bounds the rows they scale
        sink below round-off (or swamp the others) and the solve loses them."""
        lo, hi = (self._kappa * f for f in ROW_SCALES)
        if lo <= rho <= hi:
            return rho
        bounded = min(max(rho, lo), hi)
        self.warnings.append(
            f"contact.{key} = {given if given is not None else rho:.6g} {unit} scales the rows of the "
            f"conditions {rho / self._kappa:.3g} times E/h: they are scaled {bounded / self._kappa:.3g} "
            f"times E/h instead (with integration = \"NOEUD\" the coefficients do not change the answer)")
        return bounded

    def threshold_change(self, x: PETSc.Vec, first: bool = False) -> float:
        """max |LAGS_C - s| / max |LAGS_C| at the dofs: how far the thresholds of the
        last solve are from its contact pressures (1 when ``first``: the first
        thresholds are SEUIL_INIT or none)."""
        lam = self._values(x)[2]
        if first:
            return 1.0
        return self._change(lam, np.where(self.slot, self._threshold(lam), 0.0))

    def _change(self, lam, target):
        """max |target - s| / max |LAGS_C| at the dofs (all processes), ``lam`` and
        ``target`` ``(k, m)`` (Pa)."""
        num, den = self._max(np.where(self.slot, target - self.s, 0.0)), self._lam_scale(lam)
        return num / den if den > 0 else (0.0 if num == 0 else np.inf)

    def has_thresholds(self) -> bool:
        """Friction starts bounded (SEUIL_INIT) or sticking: never frictionless."""
        return True

    def unbound_friction(self) -> None:
        """Friction without bound until the next threshold update, contact statuses
        frozen: the start when the frictionless one has no equilibrium (a body held by
        the interface alone); that solve only gives the first thresholds."""
        self.unbounded = True

    def snapshot(self) -> Snapshot:
        return (self.chi.copy(), self.slip.copy(), self.s.copy(), self.extrapolated.copy(), self.unbounded,
                self.free_start)

    def restore(self, snapshot: Snapshot) -> None:
        chi, slip, s, extrapolated, self.unbounded, self.free_start = snapshot
        self.chi, self.slip, self.s = chi.copy(), slip.copy(), s.copy()
        if (extrapolated != self.extrapolated).any():
            self.extrapolated = extrapolated.copy()
            self._functions()

    def largest_threshold(self) -> float:
        return self._max(self.s)

    # -- load steps -----------------------------------------------------------------
    def begin_step(self, x: PETSc.Vec, first: bool) -> None:
        """A new load step from the converged state ``x`` of the previous one.  Statuses,
        thresholds and dependent-vertex modes carry over; friction becomes incremental
        (the slip of the step is measured from the jump of ``x``); the thresholds are
        the contact pressures of ``x``.  ``first``: the first step (nothing changes)."""
        self._seen_contact.clear()
        self._seen_slip.clear()
        self._seen_states.clear()
        self.guarded = False
        self._flips[:] = 0
        self._accelerated = self._threshold_update()
        if first:
            return
        ve, h, lam, T = self._values(x)
        self._h0 = h.copy()
        self._floor_lam = max(self._floor_lam, self._max(lam))
        self._floor_gap = max(self._floor_gap, self._gap_scale(h))
        if self.friction and not self.unbounded:
            self.s = np.where(self.slot, self._threshold(lam), 0.0)
            self._set_rho_T(self._max(self.s))
            self.carried_thresholds = True

    def state(self) -> dict[str, Any]:
        """Everything that carries from one step to the next (arrays and numbers), for
        the step cutting and the checkpoints; :meth:`set_state` puts it back."""
        return {"chi": self.chi.copy(), "slip": self.slip.copy(), "s": self.s.copy(),
                "extrapolated": self.extrapolated.copy(), "unbounded": self.unbounded,
                "free_start": self.free_start, "rho_T": self.rho_T,
                "h0": None if self._h0 is None else self._h0.copy(),
                "carried_thresholds": self.carried_thresholds,
                "floors": np.array([self._floor_lam, self._floor_gap])}

    def set_state(self, st: dict[str, Any]) -> None:
        self.restore((st["chi"], st["slip"], st["s"], st["extrapolated"], bool(st["unbounded"]),
                      bool(st["free_start"])))
        self.rho_T = None if st["rho_T"] is None else float(st["rho_T"])
        self._h0 = None if st["h0"] is None else np.array(st["h0"], dtype=float)
        self.carried_thresholds = bool(st["carried_thresholds"])
        self._floor_lam, self._floor_gap = (float(v) for v in st["floors"])
        self._seen_contact.clear()
        self._seen_slip.clear()
        self._seen_states.clear()
        self.guarded = False
        self._flips[:] = 0
        self._accelerated = self._threshold_update()

    def status_changes(self, st: dict[str, Any]) -> int:
        """Dofs (all processes) whose contact or friction status differs from ``st`` (3-D:
        slip directions by more than DIRECTION_CHANGE, not their round-off)."""
        moved = self.slip != st["slip"] if self._nf == 1 else self._moved(self.slip, st["slip"], DIRECTION_CHANGE)
        return self._count((self.chi != st["chi"]) | self._fold(moved))

    # -- results --------------------------------------------------------------------
    def vertex_values(self, x: PETSc.Vec, thresholds_from_x: bool = False) -> VertexValues:
        """Values at the vertices of the segment cells ``(k, nv)``: LAGS_C (Pa), the
        friction traction T the equilibrium holds (Pa: the dof in stick, mu |s| p in
        slip; 0 where friction is not bounded), the threshold s (Pa; with
        ``thresholds_from_x`` the LAGS_C of ``x``), contact and sliding (1/0: a
        dof it depends on is)."""
        ve, h, lam, T = self._values(x)
        active, bound = self._bounds()
        bounded = active & np.isfinite(bound)
        s = self.s
        # the traction the equilibrium holds: the dof in stick, mu |s| p in slip
        fa, fb = self._fbounds()
        T = np.where(fa & self._sliding(self.slip), np.where(fa & np.isfinite(fb), fb, 0.0) * self.slip, T)
        if thresholds_from_x:
            s = np.where(self.slot, self._threshold(lam), 0.0)
            bounded = self.slot & (s != 0) & self.friction
        Tv = self._Tv
        uses = np.abs(Tv) > 0
        Tb = np.where(self._tile(bounded), T, 0.0)
        if self._nf == 1:
            Tvert = np.einsum("kvm,km->kv", Tv, Tb)
        else:                                       # (k, nv, nf): the components
            Tvert = np.einsum("kvm,kmc->kvc", Tv, self._split(Tb))
        return (np.einsum("kvm,km->kv", Tv, lam), Tvert,
                np.einsum("kvm,km->kv", Tv, np.where(bounded, s, 0.0)),
                np.any(uses & (self.chi == 1)[:, None, :], axis=2).astype(float),
                np.any(uses & (active & self._fold(self.slip != 0))[:, None, :], axis=2).astype(float))

    def point_values(self, x: PETSc.Vec, thresholds_from_x: bool = False) -> dict[str, NDArray[Any]]:
        """Values at the interface points (2-D: the segment ends, see
        :meth:`InterfaceProblem.point_values`; 3-D: :meth:`facet_values`)."""
        if self._nf == 1:
            return super().point_values(x, thresholds_from_x)
        return self.facet_values(x, thresholds_from_x)

    def facet_values(self, x: PETSc.Vec, thresholds_from_x: bool = False) -> dict[str, NDArray[Any]]:
        """3-D: values at the Gauss points of the interface facets (one entry per point of
        non-zero weight), flat arrays: x, y, z (m), w (area weight, m^2), LAGS_C (Pa),
        LAGS_F1, LAGS_F2 (-: the tangential traction's components in the tangent basis
        (t1, t2) of :func:`~xfemcontact.xfem.integration3d.tangent_basis` over mu s,
        code_aster's semi-multipliers), T (Pa, the magnitude of the tangential traction,
        basis-free), gap (m, [u].n), slip1, slip2 (m, [u].t1, [u].t2), slip (m, the
        magnitude of the tangential jump), contact, sliding (1/0), cell (input cell
        index), end (the point's index in its element)."""
        op, pts = self._op, self.points
        ve = op.element_values(x)
        h = ve[:, :self._nh]
        gap = np.einsum("kqd,kd->kq", op.normal_operator(), h)
        s1, s2 = (np.einsum("kqd,kd->kq", a, h) for a in op.tangential_operators())
        lam, T, s, chi, sliding = self.vertex_values(x, thresholds_from_x)
        lin = self._lin
        Tq = np.einsum("kqv,kvc->kqc", lin, T)
        sq = np.einsum("kqv,kv->kq", lin, s)
        on = lin > 1e-14
        live = pts.w != 0
        k, q = pts.w.shape
        out = {"x": pts.x[..., 0], "y": pts.x[..., 1], "z": pts.x[..., 2], "w": pts.w,
               "LAGS_C": np.einsum("kqv,kv->kq", lin, lam),
               "LAGS_F1": nodal.semi_multiplier(Tq[..., 0], sq, self.mu),
               "LAGS_F2": nodal.semi_multiplier(Tq[..., 1], sq, self.mu),
               "T": np.linalg.norm(Tq, axis=-1), "gap": gap, "slip1": s1, "slip2": s2,
               "slip": np.hypot(s1, s2),
               "contact": np.max(np.where(on, chi[:, None, :], 0.0), axis=-1, initial=0.0),
               "sliding": np.max(np.where(on, sliding[:, None, :], 0.0), axis=-1, initial=0.0),
               "cell": np.repeat(self._op.mesh.cell_ids[pts.cells][:, None], q, axis=1),
               "end": np.broadcast_to(np.arange(q), (k, q))}
        return {key: np.asarray(v)[live] for key, v in out.items()}

    def _end_values(self, x: PETSc.Vec, thresholds_from_x: bool = False) -> EndValues:
        vals = self.vertex_values(x, thresholds_from_x)
        el = self._op.mesh.element
        assert self.segments is not None          # 2-D (3-D: facet_values)
        nodes = self.segments.nodes

        def values(ve: FloatArray, phi: FloatArray, end: int) -> dict[str, FloatArray]:
            return _interpolate(el.shape_linear(nodes[:, end]), *vals, self.mu)
        return values

    def segment_values(self, x: PETSc.Vec, xi: FloatArray, near: IntArray) -> dict[str, FloatArray]:
        el = self._op.mesh.element
        return _interpolate(el.shape_linear(xi), *self.vertex_values(x), self.mu, points="kp")

    def conditions(self, x: PETSc.Vec) -> dict[str, Any]:
        """How far the conditions of :mod:`xfemcontact.contact.nodal` are from holding at the
        dofs of ``x`` (a converged state), whatever the statuses say: the largest violation
        of each over every dof of every process (0 where none), relative to the scales
        returned with them: P (Pa) the largest |LAGS_C| and J (m) the largest mean gap or
        slip, J at least P / kappa and P at least OPEN_PRESSURE kappa J (kappa = E / h, the
        stiffness scale of the status test), and mu P.

        * ``tension``: max lam_a / P (<= 0); ``interpenetration``: max -gn_a / J (<= 0);
        * ``contact_complementarity``: max over dofs of min(|lam_a| / P, |gn_a| / J) (0:
          each dof is open without pressure, or closed without gap);
        * ``friction_excess``: max (|T_a| - mu |s_a|) / (mu P) (<= 0, s_a the dof's threshold),
          over the dofs in contact with a threshold (friction acts there);
        * ``friction_complementarity``: max over these dofs of min((mu |s_a| -
          |T_a|) / (mu P), |gt_a| / J) (0: each dof sticks, or slips at the bound);
        * ``slip_direction``: max over slipping dofs (|gt_a| > 1e-6 J) of (1 - cos) / 2 of the
          angle between T_a and gt_a (0: the traction along the slip, 1: against it);
        * ``threshold``: max |s_a - min(lam_a, 0)| / P (0 once Coulomb's law holds: the
          threshold is the pressure; the threshold fixed point stops at RESI_FROT).

        ``gt`` is the slip of the load step (the law is incremental).  Friction entries are
        None without friction, tension and interpenetration None for ``glissiere``
        (bilateral: contact once made is kept)."""
        ve, h, lam, T = self._values(x)
        gn = self._gap_and_tolerances(h, lam)[0]
        slot = self.slot
        gt = self._mean_slip(h if self._h0 is None else h - self._h0, lam.shape)
        vec = (lambda a: a[..., None]) if self._nf == 1 else self._split
        Tv, gv = vec(T), vec(gt)                                    # (k, m, nf)
        Tn, gtn = np.linalg.norm(Tv, axis=-1), np.linalg.norm(gv, axis=-1)
        # where nothing opens or slips the jumps are round-off themselves: J is at least the
        # elastic displacement of the pressures over a cell (P h / E); where all opens the
        # pressures are, and P is at least OPEN_PRESSURE times the stress of the jumps over a
        # cell (a slip of a whole block strains nothing: E J / h overstates the stresses)
        P0 = self._max(np.where(slot, lam, 0.0))
        J0 = max(self._max(np.where(slot, gn, 0.0)), self._max(np.where(slot, gtn, 0.0)))
        P, J = max(P0, OPEN_PRESSURE * self._kappa * J0), max(J0, P0 / self._kappa)
        rel = (lambda a, scale: a / scale if scale > 0 else np.zeros_like(a))

        def top(a, mask):
            local = float(np.max(np.where(mask, a, -np.inf), initial=-np.inf))
            return max(self._mpi.allreduce(local, op=MPI.MAX), 0.0)

        out: dict[str, Any] = {"pressure_scale_pa": P, "jump_scale_m": J}
        if not self.bilateral:
            out["tension"] = top(rel(lam, P), slot)
            out["interpenetration"] = top(rel(-gn, J), slot)
        out["contact_complementarity"] = top(np.minimum(rel(np.abs(lam), P), rel(np.abs(gn), J)), slot)
        if not self.friction:
            out.update(friction_excess=None, friction_complementarity=None, slip_direction=None,
                       threshold=None)
            return out
        on, bound = self._bounds()                 # friction acts where in contact
        mP = self.mu * P
        live = on & (bound > 0)
        out["friction_excess"] = top(rel(Tn - bound, mP), live)
        out["friction_complementarity"] = top(np.minimum(rel(bound - Tn, mP), rel(gtn, J)), live)
        slipping = live & (gtn > 1e-6 * J)
        cos = np.einsum("kmc,kmc->km", Tv, gv) / np.where(slipping, np.maximum(Tn * gtn, 1e-300), 1.0)
        out["slip_direction"] = top(0.5 * (1.0 - cos), slipping)
        out["threshold"] = top(rel(np.abs(self.s[:, :self._m] - np.minimum(lam, 0.0)), P), slot)
        return out

    def summary(self) -> dict[str, Any]:
        out = dict(self.space.summary())
        out.update({"integration": "NOEUD", "dependent_vertices": self.n_dep,
                    "friction_newton": "COULOMB" if self.coulomb_newton else "TRESCA",
                    "coef_cont_given": self._given[0], "coef_frot_given": self._given[1],
                    "cycle_guards": self.guards, "coulomb_rearms": self.rearms,
                    "convex_dependent_vertices": int((~self.extrapolated).sum()),
                    "convex_for_weight": int(self.held_convex.sum()),
                    "coef_cont": self.rho_n, "rho_T": self.rho_T, "h": self._h})
        return out


def _interpolate(lin: FloatArray, lam: FloatArray, T: FloatArray, s: FloatArray, chi: FloatArray,
                 sliding: FloatArray, mu: float, points: str = "k") -> dict[str, FloatArray]:
    """Point values from vertex values ``(k, nv)`` with the linear functions ``lin``
    (``(k, nv)`` or ``(k, p, nv)``, all >= 0): LAGS_C = lam(x); LAGS_F1 = T(x) /
    (mu s(x)), the traction over the interpolated threshold (code_aster's
    tangential traction mu s LAGS_F1); contact / sliding 1 where a vertex whose
    function is not zero there is in contact / sliding."""
    sub = "kv,kv->k" if points == "k" else "kpv,kv->kp"
    on = lin > 1e-14
    if points == "kp":
        def pick(v):
            return np.max(np.where(on, v[:, None, :], 0.0), axis=-1, initial=0.0)
    else:
        def pick(v):
            return np.max(np.where(on, v, 0.0), axis=-1, initial=0.0)
    lags_f1 = nodal.semi_multiplier(np.einsum(sub, lin, T), np.einsum(sub, lin, s), mu)
    return {"LAGS_C": np.einsum(sub, lin, lam), "LAGS_F1": lags_f1,
            "contact": pick(chi), "sliding": pick(sliding)}
