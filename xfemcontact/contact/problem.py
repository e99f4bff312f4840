"""The interface problem: the one object that owns an interface's terms and state.

    problem = laws.get(case.interface.law).problem(setup)     # xfemcontact.contact.laws

This module defines the protocol, what the model hands a law
(:class:`InterfaceSetup`) and the results-only problem of the laws without
terms (:class:`InterfaceProblem`); the contact law's problem is
:class:`~xfemcontact.contact.gauss_problem.GaussContactProblem`.

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
* ``has_thresholds()``: whether friction starts bounded (else the first threshold
  iteration is frictionless);
* when ``fallbacks`` is true (the Gauss-point form), for the fallbacks of the
  loops: ``friction_statuses(x)``, ``holding(statuses)`` (a context),
  ``unbound_friction()``, ``snapshot()`` and ``restore(snapshot)``.

Load steps (:mod:`xfemcontact.history`; the contact laws only): ``begin_step(x,
first)`` starts a step from the converged ``x`` of the previous one (statuses,
thresholds and multipliers carry over, friction counts the slip from ``x``);
``state()`` / ``set_state(state)``: everything that carries from a step to the
next, as arrays and numbers (step cutting, checkpoints); ``status_changes(state)``:
dofs or points whose statuses differ from ``state``; ``carried_thresholds``: the
thresholds come from a converged step (the threshold loop may then stop at its
first iteration).

Results: ``point_values(x)`` (the interface points), ``segment_values(x, xi,
near)`` (any points of the segments), ``summary()``; read-only facts
``segments``, ``points``, ``space``, ``rep_index``, ``phi``, ``mu`` and
``friction_unknown`` ("semi-multiplier": the friction dof holds LAGS_F1;
"traction": the tangential traction in Pa).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from xfemcontact.contact import gauss_point
from xfemcontact.contact import space as cspace
from xfemcontact.contact.operator import InterfaceOperator, PointState


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


class InterfaceProblem:
    """An interface without terms (laws ``free`` and ``bonded``): the results only.

    Gap and slip at the interface points; LAGS_C = LAGS_F1 = 0; "contact" is 1
    for a bonded interface, 0 for a free one.
    """

    loops: tuple[str, ...] = ()
    friction = False
    fallbacks = False
    carried_thresholds = False
    mu = 0.0
    friction_unknown = "semi-multiplier"     # what the friction dof holds: LAGS_F1, or the traction (Pa)
    indices = None
    pattern_points = None
    remote_points = None
    space = None
    rep_index = None

    def __init__(self, setup: InterfaceSetup, bonded: bool = False):
        self.comm = setup.mesh.comm
        self.warnings: list[str] = []        # of the set-up, one line each
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

    # -- load steps: nothing carries ---------------------------------------------------
    def begin_step(self, x, first: bool) -> None:
        return None

    def state(self) -> dict:
        return {}

    def set_state(self, st: dict) -> None:
        return None

    def status_changes(self, st: dict) -> int:
        return 0

    # -- Newton ---------------------------------------------------------------------
    def add_residual(self, x, f) -> None:
        return None

    def tangent(self, x):
        return None

    # -- results --------------------------------------------------------------------
    def point_values(self, x, thresholds_from_x: bool = False) -> dict:
        """Values at the ends of every segment (see :meth:`InterfaceOperator.point_values`).

        ``thresholds_from_x``: take the friction thresholds from the LAGS_C of ``x``
        (a field that is no solve's, such as a projection), not from the state."""
        return self._op.point_values(x, self._end_values(x, thresholds_from_x))

    def _end_values(self, x, thresholds_from_x=False):
        """The law's values at the segment ends (see :meth:`InterfaceOperator.point_values`):
        here, at the Gauss points' statuses and thresholds."""
        op, state = self._op, self._state
        nn, nv = op.nn, op.nv
        t = op.terms(x, state)

        def values(ve, phi, end):
            q = 0 if end == 0 else -1            # nearest Gauss point for the statuses
            lam_p = np.einsum("ka,ka->k", phi, ve[:, 2 * nn:2 * nn + nv])
            fric = np.einsum("ka,ka->k", phi, ve[:, 2 * nn + nv:])
            return {"LAGS_C": lam_p,
                    "LAGS_F1": gauss_point.semi_multiplier(self.law, gauss_point.threshold(lam_p), fric),
                    "contact": state.chi[:, q].astype(float),
                    "sliding": t["slip"][:, q].astype(float)}
        return values

    def segment_values(self, x, xi, near):
        return None

    def summary(self) -> dict | None:
        return None
