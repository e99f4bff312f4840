"""Unilateral contact with Coulomb friction, code_aster's continuous method at the
interface Gauss points (``[contact] integration = "GAUSS"``).

The terms are those of :mod:`xfemcontact.contact.gauss_point`; statuses and
thresholds live at the Gauss points (:class:`~xfemcontact.contact.problem.PointState`).
The protocol is that of :mod:`xfemcontact.contact.problem`, with the fallbacks
of :mod:`xfemcontact.solver.loops` (stick predictor, frictionless start redone
sticking, line search, frozen friction statuses).

Both dimensions, one code: the interface elements are the cut cells of the segments
(2-D) or of the facets (3-D: :class:`~xfemcontact.xfem.integration3d.FacetPoints`), the
friction dofs and fields have nf = d - 1 components in the tangent basis (3-D: LAGS_F1,
LAGS_F2 along t1, t2 of :func:`~xfemcontact.xfem.integration3d.tangent_basis`), and the
law projects the trial value on Coulomb's disc (:func:`gauss_point.disc_terms`; in 2-D
the interval, with the same arithmetic as before).  In 3-D the friction statuses the
loops' fallbacks compare and hold are the slip directions ``(k, ng, 2)``.
"""
from __future__ import annotations

from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, Iterator

import numpy as np

from xfemcontact import options
from xfemcontact.contact import gauss_point
from xfemcontact.contact.dofmap import multiplier_dofs
from xfemcontact.contact.operator import InterfaceOperator
from xfemcontact.contact.problem import InterfaceProblem, InterfaceSetup, PointState
from xfemcontact.contact.scales import coefficients

if TYPE_CHECKING:
    from mpi4py import MPI
    from numpy.typing import NDArray
    from petsc4py import PETSc

    from xfemcontact.contact.problem import Remote
    from xfemcontact.contact.space import MultiplierSpace

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]
    #: the fields at the Gauss points (k, ng): gap, tangential jump, LAGS_C, friction dof
    Fields = tuple[FloatArray, FloatArray, FloatArray, FloatArray]


#: 3-D: the slip directions :meth:`GaussContactProblem.friction_statuses` hands the loops are
#: rounded to this many decimals (the frozen-status fallback compares statuses exactly)
DIRECTION_DIGITS = 8


class GaussContactProblem(InterfaceProblem):
    """Unilateral contact with Coulomb friction: code_aster's continuous method at the
    interface Gauss points (:mod:`xfemcontact.contact.gauss_point`)."""

    fallbacks = True
    # facts of the protocol, never None here
    law: gauss_point.PointLaw
    indices: IntArray
    rep_index: IntArray
    pattern_points: IntArray
    remote_points: Remote
    space: MultiplierSpace
    phi: FloatArray
    # state that starts unset (None)
    _natural_frot: float | None
    _previous_lags_c: FloatArray | None

    def __init__(self, setup: InterfaceSetup) -> None:
        mesh, c = setup.mesh, setup.case.contact
        self.comm = mesh.comm
        self.warnings = []
        self.segments = setup.geo.segments() if mesh.dim == 2 else None     # 3-D: facets
        self.points, self.space = setup.points, setup.space
        cells = self.segments.cells if self.segments is not None else setup.points.cells
        dofs = multiplier_dofs(mesh, setup.layout, setup.space, cells)
        self.rep_index = dofs.rep_index
        self.pattern_points, self.remote_points = dofs.element_points, dofs.remote_points
        unknown = options.get("friction_unknown", c.friction_unknown)      # -xfc_friction_unknown, checked
        scales = coefficients(setup.case, mesh, setup.geo)
        # without COEF_FROT: E / (h mu |p|), p = SEUIL_INIT or the first threshold (see update_threshold)
        self._natural_frot = None
        coef_frot = c.coef_frot
        if coef_frot is None:
            self._natural_frot = setup.case.material.E / scales.h
            p = abs(c.seuil_init or 0.0)
            coef_frot = self._natural_frot / (c.coulomb * p) if c.coulomb > 0 and p > 0 else 1.0
            self._natural_frot = None if p > 0 else self._natural_frot
        rho_T = max(scales.coef_cont, c.coulomb * coef_frot * abs(c.seuil_init or 0.0))
        self.law = gauss_point.PointLaw(scales.coef_cont, coef_frot, c.coulomb, c.friction,
                                        unknown="traction" if unknown == "TRACTION" else "semi-multiplier",
                                        rho_T=rho_T)
        self.friction = self.law.friction
        self.mu, self.friction_unknown = self.law.mu, self.law.unknown
        self.loops = ("contact", "friction") if self.friction else ("contact",)
        self._op = InterfaceOperator(mesh, setup.geo, setup.layout, setup.space, self.rep_index,
                                     self.law, setup.points)
        self.indices = self._op.gidx
        self.phi = self._op.phi
        self._nf = mesh.dim - 1                  # friction components (3-D: LAGS_F1, LAGS_F2)
        shape = setup.points.w.shape
        self._state = PointState(np.full(shape, 1 if c.contact_init is not False else 0, dtype=np.int64),
                                 np.full(shape, float(c.seuil_init) if c.seuil_init is not None else 0.0))
        self._previous_lags_c = None

    # -- Newton ---------------------------------------------------------------------
    def add_residual(self, x: PETSc.Vec, f: PETSc.Vec) -> None:
        self._op.add_residual(x, f, self._state)

    def tangent(self, x: PETSc.Vec) -> FloatArray:
        return self._op.element_matrices(x, self._state)

    def add_matrices(self, J: PETSc.Mat, K: FloatArray) -> None:
        self._op.add_matrices(J, K)

    def add_product(self, K: FloatArray, x: PETSc.Vec, f: PETSc.Vec, scale: float = 1.0) -> None:
        self._op.add_product(K, x, f, scale)

    # -- outer loops ----------------------------------------------------------------
    def _mpi(self) -> MPI.Comm:
        return self.comm.tompi4py()

    def _fields(self, x: PETSc.Vec) -> Fields:
        return self._op.point_fields(self._op.element_values(x))

    def _components(self, ut0: FloatArray) -> FloatArray:
        """Tangential jumps of a saved state as ``(k, ng, nf)`` (2-D states saved before the
        components were explicit are ``(k, ng)``)."""
        return ut0[..., None] if ut0.ndim == 2 else ut0

    def update_status(self, x: PETSc.Vec) -> int:
        """Apply the status test; returns the number of points (all processes) that changed."""
        g, ut, lam, Lam = self._fields(x)
        new = gauss_point.update_status(self.law, self._state.chi, g, lam)
        if self.bilateral:                       # GLISSIERE: contact once made is kept
            new = np.maximum(new, self._state.chi)
        changed = int((new != self._state.chi).sum())
        self._state.chi = new
        return self._mpi().allreduce(changed)

    def update_threshold(self, x: PETSc.Vec) -> BoolArray:
        """s <- LAGS_C.  Returns the mask ``(k, ng)`` of points in contact whose friction
        this update switches on or bounds for the first time (threshold zero or
        unbounded before, not zero now)."""
        g, ut, lam, Lam = self._fields(x)
        st = self._state
        fresh = (st.s == 0) | st.unbounded
        st.unbounded = False
        st.s = gauss_point.threshold(lam)
        if self._natural_frot is not None:          # COEF_FROT not given, no SEUIL_INIT
            p = self.largest_threshold()
            if p > 0 and self.law.mu > 0:
                self.law.coef_frot = self._natural_frot / (self.law.mu * p)
                self._natural_frot = None
        return (st.chi == 1) & fresh & (st.s != 0)

    def threshold_change(self, x: PETSc.Vec, first: bool = False) -> float:
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

    def _lags_c_dofs(self, x: PETSc.Vec) -> FloatArray:
        """LAGS_C dof values of this process's interface elements."""
        ve = self._op.element_values(x)
        nh, nv = self._op.d * self._op.nn, self._op.nv
        return ve[:, nh:nh + nv][self.indices[:, nh:nh + nv] >= 0]

    def has_thresholds(self) -> bool:
        """Whether any point has a non-zero friction threshold (collective)."""
        return bool(self._mpi().allreduce(int(np.count_nonzero(self._state.s))))

    def friction_statuses(self, x: PETSc.Vec) -> FloatArray:
        """The friction statuses at ``x``: 2-D ``(k, ng)``, 0 stick, +-1 slip direction; 3-D
        ``(k, ng, 2)``, 0 stick, the unit slip direction in the tangent basis rounded to
        :data:`DIRECTION_DIGITS` decimals (so that the loops, which compare statuses, take a
        direction that moved by round-off for the same status)."""
        g, ut, lam, Lam = self._fields(x)
        st = self._state
        if st.ut0 is not None:
            ut = ut - st.ut0
        status = gauss_point.friction_status(self.law, st.chi, st.s, ut, Lam)
        return status[..., 0] if self._nf == 1 else np.round(status, DIRECTION_DIGITS)

    @contextmanager
    def holding(self, statuses: FloatArray) -> Iterator[None]:
        """Friction statuses imposed on the points for a block: ``(k, ng)`` (0 stick, +-1
        slip in 2-D, NaN: the trial value decides; in 3-D 0 and NaN only, for every
        component) or ``(k, ng, nf)`` (:meth:`friction_statuses`)."""
        held = np.asarray(statuses, dtype=float)
        if held.ndim == 2:
            held = np.repeat(held[..., None], self._nf, axis=-1)
        self._state.held = held
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

    # -- load steps -----------------------------------------------------------------
    def begin_step(self, x: PETSc.Vec, first: bool) -> None:
        """A new load step from the converged ``x``: statuses carry over, the thresholds
        are the contact pressures of ``x`` at the Gauss points, friction counts the
        tangential jump from that of ``x``.  ``first``: the first step (nothing changes)."""
        if first:
            return
        g, ut, lam, Lam = self._fields(x)
        st = self._state
        st.ut0 = ut.copy()                       # (k, ng, nf)
        if self.friction and not st.unbounded:
            st.s = gauss_point.threshold(lam)
            self._previous_lags_c = self._lags_c_dofs(x)
            self.carried_thresholds = True

    def state(self) -> dict[str, Any]:
        st = self._state
        return {"chi": st.chi.copy(), "s": st.s.copy(), "unbounded": st.unbounded,
                "ut0": None if st.ut0 is None else st.ut0.copy(),
                "coef_frot": self.law.coef_frot, "natural_frot": self._natural_frot,
                "previous_lags_c": None if self._previous_lags_c is None else self._previous_lags_c.copy(),
                "carried_thresholds": self.carried_thresholds}

    def set_state(self, d: dict[str, Any]) -> None:
        self._state = PointState(np.array(d["chi"]).astype(np.int64), np.array(d["s"], dtype=float),
                                 None, bool(d["unbounded"]),
                                 None if d["ut0"] is None else self._components(np.array(d["ut0"], dtype=float)))
        self.law.coef_frot = float(d["coef_frot"])
        self._natural_frot = None if d["natural_frot"] is None else float(d["natural_frot"])
        self._previous_lags_c = None if d["previous_lags_c"] is None else np.array(d["previous_lags_c"])
        self.carried_thresholds = bool(d["carried_thresholds"])

    def status_changes(self, d: dict[str, Any]) -> int:
        """Interface Gauss points (all processes) whose contact status differs from ``d``."""
        return self._mpi().allreduce(int((self._state.chi != d["chi"]).sum()))

    def largest_threshold(self) -> float:
        """max |s| over every process (Pa)."""
        from mpi4py import MPI

        return self._mpi().allreduce(float(np.abs(self._state.s).max(initial=0.0)), op=MPI.MAX)

    # -- results --------------------------------------------------------------------
    def segment_values(self, x: PETSc.Vec, xi: FloatArray, near: IntArray) -> dict[str, FloatArray]:
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
        fric = np.einsum("kpa,ka->kp", phi, ve[:, 2 * nn + nv:])            # 2-D: one component
        return {"LAGS_C": lam,
                "LAGS_F1": gauss_point.semi_multiplier(self.law, gauss_point.threshold(lam), fric),
                "contact": self._state.chi[:, near].astype(float),
                "sliding": terms["slip"][:, near].astype(float)}

    def surface_values(self, x: PETSc.Vec, xi: FloatArray, thresholds_from_x: bool = False
                       ) -> dict[str, FloatArray]:
        """3-D: the interface fields at parent reference points ``xi (k, p, 3)`` of the
        interface cells (see :meth:`InterfaceProblem.surface_values`): LAGS_C (Pa) and the
        friction dofs interpolated with the multiplier functions; LAGS_F1, LAGS_F2 the
        semi-multipliers (with the traction unknown: its components over mu s(x), s(x) the
        threshold of the interpolated LAGS_C, as in 2-D); T (Pa) the traction's magnitude,
        mu |s(x)| |(LAGS_F1, LAGS_F2)|; contact and sliding (1/0) the statuses of the element's
        nearest Gauss point.  ``thresholds_from_x`` changes nothing: the thresholds of the
        results are those of the interpolated LAGS_C already."""
        op, law = self._op, self.law
        out = self._jumps_at(x, xi)
        ve = op.element_values(x)
        phi = self.space.functions(op.mesh.element.shape_linear(xi))                # (k, p, m)
        nh, nv = op.d * op.nn, op.nv
        lam = np.einsum("kpa,ka->kp", phi, ve[:, nh:nh + nv])
        F = np.stack([np.einsum("kpa,ka->kp", phi, ve[:, nh + (c + 1) * nv:nh + (c + 2) * nv])
                      for c in range(self._nf)], axis=-1)                           # (k, p, 2)
        s = gauss_point.threshold(lam)
        semi = gauss_point.semi_multiplier(law, s, F)
        T = gauss_point.magnitude(F if law.unknown == "traction" else np.abs(law.mu * s)[..., None] * F)
        near = self._nearest(xi)
        rows = np.arange(len(xi))[:, None]
        slip = op.terms(x, self._state)["slip"]
        out.update({"LAGS_C": lam, "LAGS_F1": semi[..., 0], "LAGS_F2": semi[..., 1], "T": T,
                    "contact": self._state.chi[rows, near].astype(float),
                    "sliding": slip[rows, near].astype(float)})
        return out

    def _nearest(self, xi: FloatArray, batch: int = 256) -> IntArray:
        """``(k, p)``: the Gauss point of non-zero weight of each element nearest (in the
        parent's reference coordinates) to each of the points ``xi (k, p, d)``; by batches of
        ``batch`` elements (the distances are ``(batch, p, ng)``)."""
        pts = self.points
        out = np.zeros(xi.shape[:2], np.int64)
        for lo in range(0, len(xi), batch):
            a, b, w = xi[lo:lo + batch], pts.xi[lo:lo + batch], pts.w[lo:lo + batch]
            d2 = (np.einsum("kpi,kpi->kp", a, a)[:, :, None] + np.einsum("kqi,kqi->kq", b, b)[:, None, :]
                  - 2.0 * np.einsum("kpi,kqi->kpq", a, b))
            out[lo:lo + batch] = np.where(w[:, None, :] != 0, d2, np.inf).argmin(axis=2)
        return out

    def summary(self) -> dict[str, Any]:
        return self.space.summary()
