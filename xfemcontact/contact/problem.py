"""The interface problem: the one object that owns an interface's terms and state.

    problem = laws.get(case.interface.law).problem(setup)     # xfemcontact.contact.laws

The model's Newton callbacks, the solver's outer loops and the post-processing
use the protocol below.  Nothing outside changes the state: statuses,
thresholds and multipliers are the problem's.

Newton (:class:`xfemcontact.model.Model`):

* ``indices`` ``(k, nd)``: global dofs of the interface elements (-1: none);
  ``pattern_points`` and ``remote_points``: the same as points of the matrix
  pattern (None: no interface element);
* ``add_residual(x, f)``: ``f += R_interface(x)``;
* ``tangent(x)``: the element tangents ``(k, nd, nd)`` at ``x`` (None: no terms);
  ``add_matrices(J, K)``: ``J += K``; ``add_product(K, x, f, scale)``:
  ``f += scale K x``.

Outer loops (:mod:`xfemcontact.solver.loops`; ``loops`` names the ones the
problem needs, innermost first):

* ``update_status(x) -> int``: the contact status test; points changed (all processes);
* ``update_threshold(x) -> mask``: s <- LAGS_C; the points whose friction this
  bounds for the first time (for the stick predictor);
* ``threshold_change(x) -> float``: relative change of LAGS_C since the last call;
* for the fallbacks of the loops: ``has_thresholds()``, ``friction_statuses(x)``,
  ``holding(statuses)`` (a context), ``unbound_friction()``, ``snapshot()`` and
  ``restore(snapshot)``.

Results: ``point_values(x)`` (the interface points), ``segment_values(x, xi,
near)`` (any points of the segments), ``summary()``; read-only facts
``segments``, ``points``, ``space``, ``rep_index``, ``phi``, ``law``.
"""
from __future__ import annotations

import dataclasses
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from xfemcontact._petsc import PETSc
from xfemcontact.contact import gauss_point
from xfemcontact.contact import space as cspace
from xfemcontact.contact.dofmap import multiplier_dofs
from xfemcontact.contact.operator import InterfaceOperator


@dataclass
class InterfaceSetup:
    """What the model hands an interface law, once, to build its problem.

    ``mesh`` (:class:`~xfemcontact.mesh.plex.Mesh`), ``geo`` (cut geometry,
    :mod:`xfemcontact.xfem.geometry`), ``layout``
    (:class:`~xfemcontact.dofs.layout.DofLayout`), ``points``
    (:class:`~xfemcontact.xfem.integration.SegmentPoints` of ``geo.segments()``),
    ``space`` (the multiplier space, None without multipliers) and ``case``.
    """

    mesh: Any
    geo: Any
    layout: Any
    points: Any
    space: Any
    case: Any


@dataclass
class PointState:
    """Contact state at the interface Gauss points ``(k, ng)``.

    ``chi``: contact status (1 in contact); ``s``: friction threshold (Pa,
    negative in compression); ``held``: friction statuses imposed on the points
    (0 stick, +-1 slip in that direction, NaN free) or None; ``unbounded``:
    friction without bound (every point in contact sticks).
    """

    chi: np.ndarray
    s: np.ndarray
    held: np.ndarray | None = None
    unbounded: bool = False

    def copy(self) -> PointState:
        return dataclasses.replace(self, chi=self.chi.copy(), s=self.s.copy(),
                                   held=None if self.held is None else self.held.copy())


class InterfaceProblem:
    """An interface without terms (laws ``free`` and ``bonded``): the results only.

    Gap and slip at the interface points; LAGS_C = LAGS_F1 = 0; "contact" is 1
    for a bonded interface, 0 for a free one.
    """

    loops: tuple[str, ...] = ()
    friction = False
    indices = None
    pattern_points = None
    remote_points = None
    space = None
    rep_index = None

    def __init__(self, setup: InterfaceSetup, bonded: bool = False):
        self.comm = setup.mesh.comm
        segs = setup.geo.segments()
        k, nv = len(segs), setup.mesh.element.nv
        self.segments, self.points = segs, setup.points
        empty = cspace.MultiplierSpace(np.zeros(0, np.int64), np.zeros(0, np.int64), None,
                                       np.zeros((k, 0), np.int64), np.zeros((k, nv, 0)), algo="NON")
        self.law = gauss_point.PointLaw(1.0, 1.0, 0.0, False)
        self._op = InterfaceOperator(setup.mesh, setup.geo, setup.layout, empty,
                                     np.zeros((k, 0), np.int64), self.law, setup.points)
        shape = setup.points.w.shape
        self._state = PointState(np.full(shape, 1 if bonded else 0, dtype=np.int64), np.zeros(shape))

    # -- Newton ---------------------------------------------------------------------
    def add_residual(self, x, f) -> None:
        return None

    def tangent(self, x):
        return None

    # -- results --------------------------------------------------------------------
    def point_values(self, x) -> dict:
        """Values at the ends of every segment (see :meth:`InterfaceOperator.point_values`)."""
        return self._op.point_values(x, self._state)

    def segment_values(self, x, xi, near):
        return None

    def summary(self) -> dict | None:
        return None


class ContactProblem(InterfaceProblem):
    """Unilateral contact with Coulomb friction: code_aster's continuous method at the
    interface Gauss points (:mod:`xfemcontact.contact.gauss_point`)."""

    def __init__(self, setup: InterfaceSetup):
        mesh, c = setup.mesh, setup.case.contact
        self.comm = mesh.comm
        self.segments, self.points, self.space = setup.geo.segments(), setup.points, setup.space
        dofs = multiplier_dofs(mesh, setup.layout, setup.space, self.segments)
        self.rep_index = dofs.rep_index
        self.pattern_points, self.remote_points = dofs.element_points, dofs.remote_points
        unknown = PETSc.Options().getString("xfc_friction_unknown", c.friction_unknown).upper()
        rho_T = max(c.coef_cont, c.coulomb * c.coef_frot * abs(c.seuil_init or 0.0))
        self.law = gauss_point.PointLaw(c.coef_cont, c.coef_frot, c.coulomb, c.friction,
                                        unknown="traction" if unknown == "TRACTION" else "semi-multiplier",
                                        rho_T=rho_T)
        self.friction = self.law.friction
        self.loops = ("contact", "friction") if self.friction else ("contact",)
        self._op = InterfaceOperator(mesh, setup.geo, setup.layout, setup.space, self.rep_index,
                                     self.law, setup.points)
        self.indices = self._op.gidx
        self.phi = self._op.phi
        shape = setup.points.w.shape
        self._state = PointState(np.full(shape, 1 if c.contact_init is not False else 0, dtype=np.int64),
                                 np.full(shape, float(c.seuil_init) if c.seuil_init is not None else 0.0))
        self._previous_lags_c = None

    # -- Newton ---------------------------------------------------------------------
    def add_residual(self, x, f) -> None:
        self._op.add_residual(x, f, self._state)

    def tangent(self, x) -> np.ndarray:
        return self._op.element_matrices(x, self._state)

    def add_matrices(self, J, K) -> None:
        self._op.add_matrices(J, K)

    def add_product(self, K, x, f, scale=1.0) -> None:
        self._op.add_product(K, x, f, scale)

    # -- outer loops ----------------------------------------------------------------
    def _mpi(self):
        return self.comm.tompi4py()

    def _fields(self, x):
        return self._op.point_fields(self._op.element_values(x))

    def update_status(self, x) -> int:
        """Apply the status test; returns the number of points (all processes) that changed."""
        g, ut, lam, Lam = self._fields(x)
        new = gauss_point.update_status(self.law, self._state.chi, g, lam)
        changed = int((new != self._state.chi).sum())
        self._state.chi = new
        return self._mpi().allreduce(changed)

    def update_threshold(self, x) -> np.ndarray:
        """s <- LAGS_C.  Returns the mask ``(k, ng)`` of points in contact whose friction
        this update switches on or bounds for the first time (threshold zero or
        unbounded before, not zero now)."""
        g, ut, lam, Lam = self._fields(x)
        st = self._state
        fresh = (st.s == 0) | st.unbounded
        st.unbounded = False
        st.s = gauss_point.threshold(lam)
        return (st.chi == 1) & fresh & (st.s != 0)

    def threshold_change(self, x, first: bool = False) -> float:
        """max |LAGS_C - LAGS_C of the previous call| / max |LAGS_C| over the multiplier
        dofs of every process; 1 when ``first`` (the first threshold iteration: the
        reference is zero).  Collective."""
        from mpi4py import MPI

        lam = self._lags_c_dofs(x)
        previous, self._previous_lags_c = self._previous_lags_c, lam
        if first or previous is None:
            return 1.0
        mpi = self._mpi()
        num = mpi.allreduce(float(np.abs(lam - previous).max(initial=0.0)), op=MPI.MAX)
        den = mpi.allreduce(float(np.abs(lam).max(initial=0.0)), op=MPI.MAX)
        return num / den if den > 0 else (0.0 if num == 0 else np.inf)

    def _lags_c_dofs(self, x):
        """LAGS_C dof values of this process's interface elements."""
        ve = self._op.element_values(x)
        nn, nv = self._op.nn, self._op.nv
        return ve[:, 2 * nn:2 * nn + nv][self.indices[:, 2 * nn:2 * nn + nv] >= 0]

    def has_thresholds(self) -> bool:
        """Whether any point has a non-zero friction threshold (collective)."""
        return bool(self._mpi().allreduce(int(np.count_nonzero(self._state.s))))

    def friction_statuses(self, x) -> np.ndarray:
        """``(k, ng)`` friction status at ``x``: 0 stick, +-1 slip direction."""
        g, ut, lam, Lam = self._fields(x)
        st = self._state
        return gauss_point.friction_status(self.law, st.chi, st.s, ut, Lam)

    @contextmanager
    def holding(self, statuses):
        """Friction statuses imposed on the points for a block (0 stick, +-1 slip,
        NaN: the trial value decides)."""
        self._state.held = statuses
        try:
            yield
        finally:
            self._state.held = None

    def unbound_friction(self) -> None:
        """Friction without bound until the next threshold update: every point in
        contact sticks (the start when the frictionless one has no equilibrium)."""
        self._state.unbounded = True

    def snapshot(self) -> PointState:
        return self._state.copy()

    def restore(self, snapshot: PointState) -> None:
        self._state = snapshot.copy()

    def largest_threshold(self) -> float:
        """max |s| over every process (Pa)."""
        from mpi4py import MPI

        return self._mpi().allreduce(float(np.abs(self._state.s).max(initial=0.0)), op=MPI.MAX)

    # -- results --------------------------------------------------------------------
    def segment_values(self, x, xi, near) -> dict:
        """LAGS_C, LAGS_F1 ``(k, p)`` at the reference points ``xi (k, p, 2)`` of the
        segment cells, and the statuses "contact", "sliding" ``(k, p)`` of the Gauss
        points ``near (p,)``."""
        op = self._op
        el = op.mesh.element
        ve = op.element_values(x)
        terms = op.terms(x, self._state)
        nn, nv = op.nn, op.nv
        phi = self.space.functions(el.shape_linear(xi))
        lam = np.einsum("kpa,ka->kp", phi, ve[:, 2 * nn:2 * nn + nv])
        fric = np.einsum("kpa,ka->kp", phi, ve[:, 2 * nn + nv:])
        return {"LAGS_C": lam,
                "LAGS_F1": gauss_point.semi_multiplier(self.law, gauss_point.threshold(lam), fric),
                "contact": self._state.chi[:, near].astype(float),
                "sliding": terms["slip"][:, near].astype(float)}

    def summary(self) -> dict:
        return self.space.summary()
