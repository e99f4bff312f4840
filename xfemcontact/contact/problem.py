"""The interface problem: the one object that owns an interface's terms and state.

    problem = laws.get(case.interface.law).problem(setup)     # xfemcontact.contact.laws

This module defines the protocol, what the model hands a law
(:class:`InterfaceSetup`) and the results-only problem of the laws without
terms (:class:`InterfaceProblem`, the base of every problem: it declares the
whole protocol, with the types of its facts; the methods of the outer loops
raise NotImplementedError there); the contact law's problems are
:class:`~xfemcontact.contact.nodal_problem.NodalContactProblem` and
:class:`~xfemcontact.contact.gauss_problem.GaussContactProblem`.

The model's Newton callbacks, the solver's outer loops and the post-processing
use the protocol below.  Nothing outside changes the state: statuses,
thresholds and multipliers are the problem's.

Newton (:class:`xfemcontact.model.Model`):

* ``indices`` ``(k, nd)``: global dofs of the interface elements (-1: none);
  ``pattern_points`` and ``remote_points``: the same as points of the matrix
  pattern (None: no interface element);
* ``add_residual(x, f)``: ``f += R_interface(x)``;
* ``tangent(x)``: the element tangents ``(k, nd, nd)`` at ``x`` (None: no terms), the
  symmetric part that is factorised; ``coupling()``: the non-symmetric rest of that
  tangent (None: none), applied by :mod:`xfemcontact.solver.operator`;
  ``add_matrices(J, K)``: ``J += K``; ``add_product(K, x, f, scale)``:
  ``f += scale K x``;
* optional (the conditions at the dofs, in load steps): ``friction_settled(x)``
  and ``residual_norm(F)`` (see :class:`xfemcontact.solver.newton.LoadRelativeTest`).

Outer loops (:mod:`xfemcontact.solver.loops`; ``loops`` names the ones the
problem needs, innermost first):

* ``update_status(x) -> int``: the contact status test; points changed (all processes);
* ``update_threshold(x) -> mask``: s <- LAGS_C; the points whose friction this
  bounds for the first time (for the stick predictor);
* ``threshold_change(x) -> float``: relative change of LAGS_C since the last call;
* ``has_thresholds()``: whether friction starts bounded (else the first threshold
  iteration is frictionless);
* ``unbound_friction()``, ``snapshot()`` and ``restore(snapshot)`` (the
  frictionless start redone sticking);
* when ``fallbacks`` is true (the Gauss-point form), for the fallbacks of the
  loops: ``friction_statuses(x)``, ``holding(statuses)`` (a context).

Load steps (:mod:`xfemcontact.history`; the contact laws only): ``begin_step(x,
first)`` starts a step from the converged ``x`` of the previous one (statuses,
thresholds and multipliers carry over, friction counts the slip from ``x``);
``state()`` / ``set_state(state)``: everything that carries from a step to the
next, as arrays and numbers (step cutting, checkpoints); ``status_changes(state)``:
dofs or points whose statuses differ from ``state``; ``carried_thresholds``: the
thresholds come from a converged step (the threshold loop may then stop at its
first iteration).

``bilateral`` (set by the law ``glissiere``, code_aster's GLISSIERE): contact once made
is kept -- the status test never releases a dof or point in contact, and tension is
admissible there.

Results: ``point_values(x)`` (the interface points), ``segment_values(x, xi,
near)`` (any points of the segments), ``summary()``, ``largest_threshold()``;
read-only facts ``comm``, ``segments``, ``points``, ``space``, ``rep_index``,
``phi`` (None without multipliers), ``law`` (the Gauss-point law, None when the
conditions are written at the dofs), ``mu`` and ``friction_unknown``
("semi-multiplier": the friction dof holds LAGS_F1; "traction": the tangential
traction in Pa).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from xfemcontact.contact import gauss_point
from xfemcontact.contact import space as cspace
from xfemcontact.contact.operator import InterfaceOperator, PointState

if TYPE_CHECKING:
    from contextlib import AbstractContextManager

    from numpy.typing import NDArray
    from petsc4py import PETSc

    from xfemcontact.contact.gauss_point import PointLaw
    from xfemcontact.contact.operator import EndValues
    from xfemcontact.contact.space import MultiplierSpace
    from xfemcontact.dofs.layout import DofLayout
    from xfemcontact.mesh.plex import LocalMesh
    from xfemcontact.xfem.cut import Segments
    from xfemcontact.xfem.geometry import Geometry
    from xfemcontact.xfem.integration import SegmentPoints
    from xfemcontact.xfem.integration3d import FacetPoints

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]
    #: remote points of the matrix pattern: (first global dof, dofs per point, owner rank)
    Remote = tuple[IntArray, IntArray, IntArray]


@dataclass
class InterfaceSetup:
    """What the model hands an interface law, once, to build its problem.

    ``mesh`` (:class:`~xfemcontact.mesh.plex.Mesh`), ``geo`` (cut geometry,
    :mod:`xfemcontact.xfem.geometry`), ``layout``
    (:class:`~xfemcontact.dofs.layout.DofLayout`), ``points``
    (:class:`~xfemcontact.xfem.integration.SegmentPoints` of ``geo.segments()``; 3-D:
    :class:`~xfemcontact.xfem.integration3d.FacetPoints` of the facets, cut cells then
    cells owning an interface face, from ``geo.interface_points``),
    ``space`` (the multiplier space, None without multipliers) and ``case``.
    """

    mesh: LocalMesh
    geo: Geometry
    layout: DofLayout
    points: SegmentPoints | FacetPoints
    space: Any           # MultiplierSpace, or None without multipliers (the laws that have them give one)
    case: Any            # xfemcontact.case.load.Case (not imported: the case package imports the laws)


class InterfaceProblem:
    """An interface without terms (laws ``free`` and ``bonded``): the results only.

    Gap and slip at the interface points; LAGS_C = LAGS_F1 = 0; "contact" is 1
    for a bonded interface, 0 for a free one.
    """

    comm: PETSc.Comm
    segments: Segments | None                # 2-D; None in 3-D (the interface is made of facets)
    points: SegmentPoints | FacetPoints      # 3-D: the facets' Gauss points (FacetPoints)
    law: PointLaw | None                     # the Gauss-point law (None: conditions at the dofs)
    warnings: list[str]                      # of the set-up, one line each (results.json)
    loops: tuple[str, ...] = ()
    friction: bool = False
    fallbacks: bool = False
    carried_thresholds: bool = False
    bilateral: bool = False                  # GLISSIERE: contact once made is kept (the contact laws' problems)
    mu: float = 0.0
    friction_unknown: str = "semi-multiplier"     # what the friction dof holds: LAGS_F1, or the traction (Pa)
    indices: IntArray | None = None
    pattern_points: IntArray | None = None
    remote_points: Remote | None = None
    space: MultiplierSpace | None = None
    rep_index: IntArray | None = None
    phi: FloatArray | None = None            # (k, ng, m) multiplier functions at the Gauss points

    def __init__(self, setup: InterfaceSetup, bonded: bool = False) -> None:
        self.comm = setup.mesh.comm
        self.warnings = []
        segs = setup.geo.segments()
        k, nv = len(segs), setup.mesh.element.nv
        self.segments, self.points = segs, setup.points
        empty = cspace.MultiplierSpace(np.zeros(0, np.int64), np.zeros(0, np.int64),
                                       cspace.topology(setup.mesh, segs), np.zeros((k, 0), np.int64),
                                       np.zeros((k, nv, 0)), np.zeros((k, nv, 0)), algo="NON")
        self.law = gauss_point.PointLaw(1.0, 1.0, 0.0, False)
        self._op = InterfaceOperator(setup.mesh, setup.geo, setup.layout, empty,
                                     np.zeros((k, 0), np.int64), self.law, setup.points)
        shape = setup.points.w.shape
        self._state = PointState(np.full(shape, 1 if bonded else 0, dtype=np.int64), np.zeros(shape))

    # -- load steps: nothing carries ---------------------------------------------------
    def begin_step(self, x: PETSc.Vec, first: bool) -> None:
        return None

    def state(self) -> dict[str, Any]:
        return {}

    def set_state(self, st: dict[str, Any]) -> None:
        return None

    def status_changes(self, st: dict[str, Any]) -> int:
        return 0

    # -- Newton ---------------------------------------------------------------------
    def add_residual(self, x: PETSc.Vec, f: PETSc.Vec) -> None:
        return None

    def tangent(self, x: PETSc.Vec) -> FloatArray | None:
        return None

    def coupling(self) -> FloatArray | None:
        """The non-symmetric part of the last tangent, element matrices ``(k, nd, nd)``
        that the Jacobian applies beside the factorised (symmetric) one (None: none)."""
        return None

    def add_matrices(self, J: PETSc.Mat, K: FloatArray) -> None:
        """``J += K``: the element tangents ``K (k, nd, nd)`` added at ``indices``."""
        self._op.add_matrices(J, K)

    def add_product(self, K: FloatArray, x: PETSc.Vec, f: PETSc.Vec, scale: float = 1.0) -> None:
        """``f += scale K x`` for the element tangents ``K (k, nd, nd)``."""
        self._op.add_product(K, x, f, scale)

    # -- outer loops: the problems whose ``loops`` name them ---------------------------
    def update_status(self, x: PETSc.Vec) -> int:
        raise NotImplementedError

    def update_threshold(self, x: PETSc.Vec) -> BoolArray:
        raise NotImplementedError

    def threshold_change(self, x: PETSc.Vec, first: bool = False) -> float:
        raise NotImplementedError

    def has_thresholds(self) -> bool:
        raise NotImplementedError

    def unbound_friction(self) -> None:
        raise NotImplementedError

    def snapshot(self) -> Any:
        """The state the loops may come back to (opaque: what :meth:`restore` takes)."""
        raise NotImplementedError

    def restore(self, snapshot: Any) -> None:
        raise NotImplementedError

    def largest_threshold(self) -> float:
        """max |friction threshold| over every process (Pa)."""
        return 0.0

    # -- the loops' fallbacks: the problems with ``fallbacks`` --------------------------
    def friction_statuses(self, x: PETSc.Vec) -> FloatArray:
        raise NotImplementedError

    def holding(self, statuses: FloatArray) -> AbstractContextManager[None]:
        raise NotImplementedError

    # -- results --------------------------------------------------------------------
    def point_values(self, x: PETSc.Vec, thresholds_from_x: bool = False) -> dict[str, NDArray[Any]]:
        """Values at the ends of every segment (see :meth:`InterfaceOperator.point_values`).

        ``thresholds_from_x``: take the friction thresholds from the LAGS_C of ``x``
        (a field that is no solve's, such as a projection), not from the state."""
        return self._op.point_values(x, self._end_values(x, thresholds_from_x))

    def _end_values(self, x: PETSc.Vec, thresholds_from_x: bool = False) -> EndValues:
        """The law's values at the segment ends (see :meth:`InterfaceOperator.point_values`):
        here, at the Gauss points' statuses and thresholds."""
        op, state, law = self._op, self._state, self.law
        assert law is not None                   # the results-only and Gauss-point problems have one
        nn, nv = op.nn, op.nv
        t = op.terms(x, state)

        def values(ve: FloatArray, phi: FloatArray, end: int) -> dict[str, FloatArray]:
            q = 0 if end == 0 else -1            # nearest Gauss point for the statuses
            lam_p = np.einsum("ka,ka->k", phi, ve[:, 2 * nn:2 * nn + nv])
            fric = np.einsum("ka,ka->k", phi, ve[:, 2 * nn + nv:])
            return {"LAGS_C": lam_p,
                    "LAGS_F1": gauss_point.semi_multiplier(law, gauss_point.threshold(lam_p), fric),
                    "contact": state.chi[:, q].astype(float),
                    "sliding": t["slip"][:, q].astype(float)}
        return values

    def segment_values(self, x: PETSc.Vec, xi: FloatArray, near: IntArray) -> dict[str, FloatArray] | None:
        """The values at the reference points ``xi (k, p, 2)`` of the segment cells, and
        the statuses of the Gauss points ``near (p,)`` (None: no multipliers)."""
        return None

    def summary(self) -> dict[str, Any] | None:
        return None
