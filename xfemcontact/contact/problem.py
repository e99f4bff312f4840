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
* optional (the conditions at the dofs, in load steps): ``friction_settled(x, tol)``
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

``equations_changed``: the problem's equations changed since the last Newton solve (a
status loop changed statuses; the nodal problem's dependent vertices switched modes): the
next Newton solve takes at least one iteration, whatever its starting residual.

``bilateral`` (set by the law ``glissiere``, code_aster's GLISSIERE): contact once made
is kept -- the status test never releases a dof or point in contact, and tension is
admissible there.

Results: ``point_values(x)`` (the interface points: 2-D the segment ends, 3-D the
facets' Gauss points), ``segment_values(x, xi, near)`` (2-D: any points of the
segments), ``surface_values(x, xi)`` (3-D: any points of the interface cells, such
as the facets' nodes), ``vertex_values(x)`` (the multiplier fields at the vertices of
the interface cells, None without multipliers), ``conditions(x)`` (how far the law's
conditions are from holding at the dofs of ``x``: results.json ``conditions``, None
where the problem has none to check), ``summary()``, ``largest_threshold()``;
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

from xfemcontact.contact import gauss_point, nodal
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
    #: LAGS_C, T, s, contact, sliding at the vertices of the interface cells, each (k, nv)
    #: (T (k, nv, d - 1) in 3-D: the components in the tangent basis)
    VertexValues = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]

#: the fields of :meth:`InterfaceProblem.surface_values` (3-D), each ``(k, p)``
SURFACE_FIELDS = ("LAGS_C", "LAGS_F1", "LAGS_F2", "T", "gap", "slip1", "slip2", "slip", "contact", "sliding")

#: a converged solve whose conditions at the multiplier dofs are further than this from holding,
#: relative to their scales, gets a warning.  Measured (results.json ``conditions``): the 81 case
#: files of cases/ at most 2.5e-12, the sliding campaign's 480 runs 4.6e-14; a run whose status
#: loop was forced (CONTACT3_86) up to 0.86 (bench/inclusion_family.py, TRIA6 N = 24, R = 2.1)
CONDITIONS_WARN = 1e-8
#: the entries of ``conditions`` the warning reads (``threshold`` is RESI_FROT's: the threshold
#: loop stops there by design)
CONDITIONS_CHECKED = ("tension", "interpenetration", "contact_complementarity", "friction_excess",
                      "friction_complementarity", "slip_direction")


def conditions_warning(found: dict[str, Any] | None) -> str | None:
    """The warning for the conditions ``found`` (:meth:`InterfaceProblem.conditions`) of a
    converged solve, None if each holds to :data:`CONDITIONS_WARN` (or there are none)."""
    if not found:
        return None
    worst = max(((float(found[k]), k) for k in CONDITIONS_CHECKED if found.get(k) is not None),
                default=(0.0, ""))
    if worst[0] <= CONDITIONS_WARN:
        return None
    return (f"the contact law holds at the multiplier dofs only to {worst[0]:.1e} of its scales "
            f"({worst[1]}; round-off is below {CONDITIONS_WARN:g}): this answer is not a solution of "
            "the discrete problem; see results.json \"conditions\" and the README, Checking the answer")


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

    Gap and slip at the interface points (3-D: the gap and both tangential jumps);
    LAGS_C = LAGS_F1 (= LAGS_F2 = T) = 0; "contact" is 1 for a bonded interface, 0 for
    a free one.
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
    equations_changed: bool = False
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
        mesh = setup.mesh
        self.comm = mesh.comm
        self.warnings = []
        self.points = setup.points
        k, nv = len(setup.points.cells), mesh.element.nv
        if mesh.dim == 2:
            self.segments = setup.geo.segments()
            topo = cspace.topology(mesh, self.segments)
        else:                                    # 3-D: the facets' cells
            self.segments = None
            topo = cspace.topology3d(mesh, setup.points.cells, setup.geo.phi)
        empty = cspace.MultiplierSpace(np.zeros(0, np.int64), np.zeros(0, np.int64), topo,
                                       np.zeros((k, 0), np.int64), np.zeros((k, nv, 0)), np.zeros((k, nv, 0)),
                                       algo="NON")
        self.law = gauss_point.PointLaw(1.0, 1.0, 0.0, False)
        self._op = InterfaceOperator(setup.mesh, setup.geo, setup.layout, empty,
                                     np.zeros((k, 0), np.int64), self.law, setup.points)
        shape = setup.points.w.shape
        self._bonded = bonded
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

    # -- Newton's line search on a merit function: the problems with ``line_search`` ----
    line_search: bool = False

    @property
    def merit_active(self) -> bool:
        """Whether Newton's steps are damped on the merit function now
        (:mod:`xfemcontact.solver.linesearch`)."""
        return False

    def add_merit_residual(self, x: PETSc.Vec, f: PETSc.Vec) -> None:
        """Add the interface part of the merit function's equilibrium rows to ``f``."""
        raise NotImplementedError

    def merit_norm(self, f: PETSc.Vec) -> float:
        """The merit function's norm from the rows of ``f`` (:meth:`add_merit_residual`)."""
        raise NotImplementedError

    def stall(self) -> None:
        """The merit function has stalled (Newton with the line search makes no progress)."""
        return None

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
        """Values at the ends of every segment (see :meth:`InterfaceOperator.point_values`;
        3-D: at the facets' Gauss points, :meth:`facet_values`).

        ``thresholds_from_x``: take the friction thresholds from the LAGS_C of ``x``
        (a field that is no solve's, such as a projection), not from the state."""
        if self.segments is None:
            return self.facet_values(x, thresholds_from_x)
        return self._op.point_values(x, self._end_values(x, thresholds_from_x))

    def facet_values(self, x: PETSc.Vec, thresholds_from_x: bool = False) -> dict[str, NDArray[Any]]:
        """3-D: the :meth:`surface_values` at the Gauss points of the facets (one entry per
        point of non-zero weight), flat arrays, with x, y, z (m), w (area weight, m^2),
        cell (input cell index) and end (the point's index in its element)."""
        pts = self.points
        out: dict[str, NDArray[Any]] = dict(self.surface_values(x, pts.xi, thresholds_from_x))
        k, q = pts.w.shape
        out.update({"x": pts.x[..., 0], "y": pts.x[..., 1], "z": pts.x[..., 2], "w": pts.w,
                    "cell": np.repeat(self._op.mesh.cell_ids[pts.cells][:, None], q, axis=1),
                    "end": np.broadcast_to(np.arange(q), (k, q))})
        live = pts.w != 0
        return {key: np.asarray(out[key])[live] for key in ("x", "y", "z", "w") + SURFACE_FIELDS + ("cell", "end")}

    def vertex_values(self, x: PETSc.Vec, thresholds_from_x: bool = False) -> VertexValues | None:
        """The multiplier fields at the vertices of the interface cells (see
        :meth:`NodalContactProblem.vertex_values`); None: no multipliers."""
        return None

    def surface_values(self, x: PETSc.Vec, xi: FloatArray, thresholds_from_x: bool = False
                       ) -> dict[str, FloatArray]:
        """3-D: the interface fields at parent reference points ``xi (k, p, 3)`` of the
        interface cells (the rows of ``points``; any points: the Gauss points, the facets'
        nodes), each ``(k, p)``: LAGS_C (Pa), LAGS_F1, LAGS_F2 (-: the tangential traction's
        components in the tangent basis (t1, t2) over mu s, code_aster's semi-multipliers),
        T (Pa, its magnitude: basis-free), gap, slip1, slip2 (m: [u].n, [u].t1, [u].t2),
        slip (m, the magnitude of the tangential jump), contact, sliding (1/0: a vertex
        whose function is not zero there is), and ``normal``, ``t1``, ``t2`` ``(k, p, 3)``
        (the unit normal from - to + and the tangent basis).  The multipliers interpolate
        :meth:`vertex_values` with the vertex functions; without multipliers they are 0,
        contact is 1 for a bonded interface and 0 for a free one, sliding 0."""
        op = self._op
        out = self._jumps_at(x, xi)
        vv = self.vertex_values(x, thresholds_from_x)
        if vv is None:
            zero = np.zeros(xi.shape[:2])
            out.update({"LAGS_C": zero, "LAGS_F1": zero, "LAGS_F2": zero, "T": zero, "sliding": zero,
                        "contact": np.full(xi.shape[:2], 1.0 if self._bonded else 0.0)})
            return out
        lam, T, s, chi, sliding = vv
        lin = op.mesh.element.shape_linear(xi)                                       # (k, p, nv)
        Tq = np.einsum("kpv,kvc->kpc", lin, T)
        sq = np.einsum("kpv,kv->kp", lin, s)
        on = lin > 1e-14
        out.update({"LAGS_C": np.einsum("kpv,kv->kp", lin, lam),
                    "LAGS_F1": nodal.semi_multiplier(Tq[..., 0], sq, self.mu),
                    "LAGS_F2": nodal.semi_multiplier(Tq[..., 1], sq, self.mu),
                    "T": np.linalg.norm(Tq, axis=-1),
                    "contact": np.max(np.where(on, chi[:, None, :], 0.0), axis=-1, initial=0.0),
                    "sliding": np.max(np.where(on, sliding[:, None, :], 0.0), axis=-1, initial=0.0)})
        return out

    def _jumps_at(self, x: PETSc.Vec, xi: FloatArray) -> dict[str, FloatArray]:
        """3-D: the kinematic part of :meth:`surface_values` at ``xi (k, p, 3)``: gap, slip1,
        slip2, slip ``(k, p)`` (m), normal, t1, t2 ``(k, p, 3)``."""
        op = self._op
        n, basis = op.frame_at(xi)
        jump = op.jump_at(op.element_values(x), xi)
        s1, s2 = (np.einsum("kpi,kpi->kp", jump, basis[..., c]) for c in range(2))
        return {"gap": np.einsum("kpi,kpi->kp", jump, n), "slip1": s1, "slip2": s2, "slip": np.hypot(s1, s2),
                "normal": n, "t1": basis[..., 0], "t2": basis[..., 1]}

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

    def conditions(self, x: PETSc.Vec) -> dict[str, Any] | None:
        """How far the law's conditions are from holding at ``x`` (None: no conditions to
        check; see :meth:`xfemcontact.contact.nodal_problem.NodalContactProblem.conditions`)."""
        return None

    def wants_coarse_start(self, x: PETSc.Vec) -> bool:
        """After the first threshold iteration: whether its answer ``x`` should be replaced by
        the solution in a coarser multiplier space (:meth:`xfemcontact.model.Model.coarse_start`)
        before Newton goes on (all processes)."""
        return False

    def check_conditions(self, x: PETSc.Vec) -> None:
        """After a converged solve: a warning (:attr:`warnings`) if the law's conditions at the
        dofs of ``x`` are further than :data:`CONDITIONS_WARN` from holding (all processes)."""
        note = conditions_warning(self.conditions(x))
        if note is not None:
            self.warnings.append(note)

    def summary(self) -> dict[str, Any] | None:
        return None
