"""Interface terms: contact and friction on every interface Gauss point, by batches.

An interface element is the segment of one owning cell.  Its dofs, in order:
H1X of the cell's nodes, H1Y of the cell's nodes, LAGS_C and LAGS_F1 of the
multiplier carriers the cell's vertices take their values from (see
:mod:`xfemcontact.contact.space`; merged vertices share one dof).  The
jump at a point is ``[u] = 2 sum_j N_j h_j`` (shifted Heaviside), so only
Heaviside dofs enter.  Values are gathered from the global solution with one
VecScatter (a merged multiplier may live on another process) and contributions
are added with ADD_VALUES (PETSc sends the off-process ones).

The operator holds no contact state: statuses and thresholds are a
:class:`PointState` passed to each call, owned by
the :class:`~xfemcontact.contact.gauss_problem.GaussContactProblem`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from xfemcontact._petsc import PETSc
from xfemcontact.contact import gauss_point as claw
from xfemcontact.xfem import integration, integration3d

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.contact.gauss_point import PointLaw
    from xfemcontact.contact.space import MultiplierSpace
    from xfemcontact.dofs.layout import DofLayout
    from xfemcontact.mesh.plex import LocalMesh
    from xfemcontact.xfem.geometry import Geometry
    from xfemcontact.xfem.integration import SegmentPoints
    from xfemcontact.xfem.integration3d import FacetPoints

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    #: a law's values at the segment ends: ``values(ve, phi, end)`` (see point_values)
    EndValues = Callable[[FloatArray, FloatArray, int], dict[str, FloatArray]]


@dataclass
class PointState:
    """Contact state at the interface Gauss points ``(k, ng)``.

    ``chi``: contact status (1 in contact); ``s``: friction threshold (Pa,
    negative in compression); ``held``: friction statuses imposed on the points
    ``(k, ng, nf)`` (0 stick, a unit direction in the tangent basis: slip along it, NaN
    free; nf = d - 1) or None; ``unbounded``: friction without bound (every point in
    contact sticks); ``ut0``: the tangential jumps ``(k, ng, nf)`` (m) at the start of the
    load step (None: 0).
    """

    chi: np.ndarray
    s: np.ndarray
    held: np.ndarray | None = None
    unbounded: bool = False
    ut0: np.ndarray | None = None

    def copy(self) -> PointState:
        return dataclasses.replace(self, chi=self.chi.copy(), s=self.s.copy(),
                                   held=None if self.held is None else self.held.copy(),
                                   ut0=None if self.ut0 is None else self.ut0.copy())


class InterfaceOperator:
    """The interface terms of the segments of every local cut cell (see the module
    documentation)."""

    def __init__(self, mesh: LocalMesh, geo: Geometry, layout: DofLayout, space: MultiplierSpace,
                 rep_index: IntArray, law: PointLaw | None, pts: SegmentPoints | FacetPoints) -> None:
        """``pts``: :class:`integration.SegmentPoints` of ``geo.segments()`` (3-D: the
        facets' :class:`integration3d.FacetPoints`); ``rep_index``
        ``(k, m)``: global LAGS_C index of the carriers of each segment cell (-1 pad);
        ``law``: the :class:`~xfemcontact.contact.gauss_point.PointLaw` (None when the
        conditions are written at the dofs: no point terms)."""
        self.mesh, self.layout, self.law = mesh, layout, law
        el = mesh.element
        self.d = d = mesh.dim
        self.segments = geo.segments() if d == 2 else None
        self.pts = pts
        nodes = mesh.cell_nodes[pts.cells]
        self.N = el.shape(self.pts.xi)                                        # (k, ng, nn)
        self.phi = space.functions(el.shape_linear(self.pts.xi))              # (k, ng, m)
        self.enr = geo.enriched[nodes]                                         # (k, nn)
        self.space = space
        #: (k, ng, d, d - 1) unit tangents (2-D: code_aster's tau; 3-D: t1, t2 of
        #: :func:`~xfemcontact.xfem.integration3d.tangent_basis`)
        self.axis = 0                   # 3-D: the axis of the tangent basis (interface_axis)
        self._phi = geo.phi
        if isinstance(pts, integration.SegmentPoints):            # 2-D
            self.tangents = pts.tangent[..., None]
        else:
            self.axis = integration3d.interface_axis(pts.normal, pts.w, mesh.comm.tompi4py())
            self.tangents = integration3d.tangent_basis(pts.normal, self.axis)
        lam_idx = rep_index                                                    # (k, m) global LAGS_C
        hg = np.where(self.enr[:, None, :], layout.h_global[nodes].transpose(0, 2, 1), -1)  # (k, d, nn)
        self.gidx = np.concatenate([hg.reshape(len(nodes), d * el.nn), lam_idx]
                                   + [np.where(lam_idx >= 0, lam_idx + c, -1) for c in range(1, d)], axis=1)
        self.nn, self.nv = el.nn, lam_idx.shape[1]
        self._scatter_setup()

    # -- gathering ----------------------------------------------------------
    def _scatter_setup(self) -> None:
        g = self.gidx
        uniq = np.unique(g[g >= 0]).astype(PETSc.IntType)
        self.uniq = uniq
        self.pos = np.where(g >= 0, np.searchsorted(uniq, np.maximum(g, 0)), -1)
        self.xg = self.layout.create_global_vec()
        self.seq = PETSc.Vec().createSeq(len(uniq), comm=PETSc.COMM_SELF)
        iset = PETSc.IS().createGeneral(uniq, comm=PETSc.COMM_SELF)
        self.scatter = PETSc.Scatter().create(self.xg, iset, self.seq, None)

    def element_values(self, x: PETSc.Vec) -> FloatArray:
        """``(k, nd)`` values of the interface dofs of ``x`` (global Vec)."""
        self.scatter.scatter(x, self.seq, addv=PETSc.InsertMode.INSERT_VALUES,
                             mode=PETSc.ScatterMode.FORWARD)
        vals = np.r_[self.seq.getArray(readonly=True), 0.0]
        return vals[self.pos]

    # -- kinematics ---------------------------------------------------------
    def point_fields(self, ve: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """The fields at the Gauss points from the element values ``ve (k, nd)``: the gap
        ``g = [u].n`` (m) ``(k, ng)``, the tangential jumps ``ut = [u].t_c`` (m) ``(k, ng, nf)``
        (nf = d - 1: 2-D code_aster's tau, 3-D t1, t2), LAGS_C (Pa) ``(k, ng)`` and the friction
        dofs' field ``(k, ng, nf)`` (LAGS_F1 [, LAGS_F2], or the traction's components, Pa)."""
        nn, nv, d = self.nn, self.nv, self.d
        jump = [2.0 * np.einsum("kqa,ka->kq", self.N, ve[:, i * nn:(i + 1) * nn]) for i in range(d)]
        g = _dot(jump, self.pts.normal)
        ut = np.stack([_dot(jump, self.tangents[..., c]) for c in range(d - 1)], axis=-1)
        lam = np.einsum("kqa,ka->kq", self.phi, ve[:, d * nn:d * nn + nv])
        start = d * nn + nv
        Lam = np.stack([np.einsum("kqa,ka->kq", self.phi, ve[:, start + c * nv:start + (c + 1) * nv])
                        for c in range(d - 1)], axis=-1)
        return g, ut, lam, Lam

    def normal_operator(self) -> FloatArray:
        """``a_n (k, ng, d nn)``: d g / d h, the gap ``g = [u].n`` (m) at the Gauss points
        as a function of the Heaviside dofs (ordered H1X of the nodes, H1Y, [H1Z])."""
        return self._project(self.pts.normal)

    def tangential_operators(self) -> list[FloatArray]:
        """``[a_t (k, ng, d nn)]``, one per tangent (2-D: tau; 3-D: t1, t2): d ([u].t) / d h."""
        return [self._project(self.tangents[..., c]) for c in range(self.d - 1)]

    def jumps(self, ve: FloatArray) -> tuple[FloatArray, list[FloatArray]]:
        """The gap ``[u].n`` and the tangential jumps ``[u].t_c`` (m), each ``(k, ng)``, at the
        Gauss points, from the element values ``ve (k, nd)`` (:meth:`element_values`)."""
        h = ve[:, :self.d * self.nn]
        return (np.einsum("kqd,kd->kq", self.normal_operator(), h),
                [np.einsum("kqd,kd->kq", a, h) for a in self.tangential_operators()])

    def frame_at(self, xi: FloatArray) -> tuple[FloatArray, FloatArray]:
        """3-D: the unit normals ``(k, p, 3)`` (grad LN / |grad LN|, from - to +) and the
        tangent bases ``(k, p, 3, 2)`` (:func:`~xfemcontact.xfem.integration3d.tangent_basis`
        with the operator's axis) at parent reference points ``xi (k, p, 3)`` of the interface
        cells: those of the Gauss points, at any points (the facets' nodes)."""
        mesh = self.mesh
        nodes = mesh.cell_nodes[self.pts.cells]
        n = integration3d.level_set_normals(mesh.element, mesh.x[nodes], self._phi[nodes], xi)
        return n, integration3d.tangent_basis(n, self.axis)

    def jump_at(self, ve: FloatArray, xi: FloatArray) -> FloatArray:
        """The jump ``[u] = u(+) - u(-) = 2 sum N_j h_j`` ``(k, p, d)`` (m) at parent reference
        points ``xi (k, p, d)`` of the interface cells, from the element values ``ve``."""
        N2 = 2.0 * self.mesh.element.shape(xi) * self.enr[:, None, :]                # (k, p, nn)
        nn = self.nn
        return np.stack([np.einsum("kpa,ka->kp", N2, ve[:, i * nn:(i + 1) * nn]) for i in range(self.d)],
                        axis=-1)

    def _project(self, v: FloatArray) -> FloatArray:
        """d ([u].v) / d h for unit vectors ``v (k, ng, d)``: [u] = 2 sum N_j h_j."""
        N2 = 2.0 * self.N * self.enr[:, None, :]
        return np.concatenate([N2 * v[..., i:i + 1] for i in range(self.d)], axis=2)

    def _operators(self) -> tuple[FloatArray, list[FloatArray]]:
        """``a_n (k, ng, d nn)`` and ``[a_t]`` (one per tangent): d g / d h and d ut_c / d h."""
        return self.normal_operator(), self.tangential_operators()

    # -- residual and tangent -------------------------------------------------
    def terms(self, x: PETSc.Vec, state: PointState) -> dict[str, FloatArray]:
        """Point terms of the law at ``x`` for the statuses and thresholds of ``state``
        (:func:`~xfemcontact.contact.gauss_point.disc_terms`: friction entries per component,
        ``(k, ng, nf)`` and ``(k, ng, nf, nf)``)."""
        law = self.law
        assert law is not None                   # point terms: a Gauss-point law
        g, ut, lam, Lam = self.point_fields(self.element_values(x))
        if state.ut0 is not None:              # friction counts the slip of the load step
            ut = ut - state.ut0
        s, held = state.s, state.held
        if state.unbounded:
            # held in stick, the solution does not depend on s; mu s = -1 Pa makes
            # LAGS_F1 the tangential traction in Pa meanwhile
            s, held = np.full(s.shape, -1.0 / law.mu), np.zeros(ut.shape)
        return claw.point_terms(law, state.chi, s, g, ut, lam, Lam, held)

    def add_residual(self, x: PETSc.Vec, f: PETSc.Vec, state: PointState) -> None:
        """``f += `` the interface residual at ``x`` (ADD_VALUES, then assembled): on the jump
        dofs sum_q w (rg a_n + sum_c rt_c a_t,c), on LAGS_C sum_q w rl phi, on the friction
        dofs of component c sum_q w rL_c phi (N, or N/m on the multipliers' rows)."""
        t = self.terms(x, state)
        w = self.pts.w
        a_n, a_t = self._operators()
        Rh = np.einsum("kq,kqd->kd", w * t["rg"], a_n)
        for c, a in enumerate(a_t):
            Rh = Rh + np.einsum("kq,kqd->kd", w * t["rt"][..., c], a)
        Rl = np.einsum("kq,kqa->ka", w * t["rl"], self.phi)
        RL = [np.einsum("kq,kqa->ka", w * t["rL"][..., c], self.phi) for c in range(len(a_t))]
        R = np.concatenate([Rh, Rl] + RL, axis=1)
        live = self.gidx >= 0           # parallel Vecs refuse negative indices
        f.setValues(self.gidx[live].astype(PETSc.IntType), R[live], addv=PETSc.InsertMode.ADD_VALUES)
        f.assemblyBegin()
        f.assemblyEnd()

    def element_matrices(self, x: PETSc.Vec, state: PointState) -> FloatArray:
        """Interface element tangents ``(k, nd, nd)`` at ``x`` (symmetric: the law's are).
        Blocks: jump-jump w (gg a_n a_n + sum_cc' tt_cc' a_c a_c'), jump-LAGS_C w gl a_n phi,
        jump-friction c' w sum_c tL_cc' a_c phi, LAGS_C-LAGS_C w ll phi phi, friction
        c-c' w LL_cc' phi phi (one NumPy expression per block and component pair over the
        batch)."""
        t = self.terms(x, state)
        w = self.pts.w
        a_n, a_t = self._operators()
        phi = self.phi
        k, nd = self.gidx.shape
        nh, nv, nf = self.d * self.nn, self.nv, len(a_t)
        K = np.zeros((k, nd, nd))
        Khh = np.einsum("kq,kqi,kqj->kij", w * t["gg"], a_n, a_n)
        for c in range(nf):
            for c2 in range(nf):
                Khh = Khh + np.einsum("kq,kqi,kqj->kij", w * t["tt"][..., c, c2], a_t[c], a_t[c2])
        K[:, :nh, :nh] = Khh
        Khl = np.einsum("kq,kqi,kqa->kia", w * t["gl"], a_n, phi)
        K[:, :nh, nh:nh + nv] = Khl
        K[:, nh:nh + nv, :nh] = Khl.transpose(0, 2, 1)
        K[:, nh:nh + nv, nh:nh + nv] = np.einsum("kq,kqa,kqb->kab", w * t["ll"], phi, phi)
        for c2 in range(nf):
            cols = slice(nh + (c2 + 1) * nv, nh + (c2 + 2) * nv)
            KhL = np.einsum("kq,kqi,kqa->kia", w * t["tL"][..., 0, c2], a_t[0], phi)
            for c in range(1, nf):
                KhL = KhL + np.einsum("kq,kqi,kqa->kia", w * t["tL"][..., c, c2], a_t[c], phi)
            K[:, :nh, cols] = KhL
            K[:, cols, :nh] = KhL.transpose(0, 2, 1)
            for c in range(nf):
                rows = slice(nh + (c + 1) * nv, nh + (c + 2) * nv)
                K[:, rows, cols] = np.einsum("kq,kqa,kqb->kab", w * t["LL"][..., c, c2], phi, phi)
        return K

    def add_matrices(self, J: PETSc.Mat, K: FloatArray) -> None:
        """``J += K`` on the interface elements (ADD_VALUES)."""
        g = self.gidx.astype(PETSc.IntType)
        if len(g) == 0:           # petsc4py divides by the batch size
            return
        J.setValuesRCV(g, g, K, addv=PETSc.InsertMode.ADD_VALUES)

    def add_product(self, K: FloatArray, x: PETSc.Vec, f: PETSc.Vec, scale: float = 1.0) -> None:
        """``f += scale * K x`` for element matrices ``K`` of the interface elements."""
        ve = self.element_values(x)
        r = scale * np.einsum("kij,kj->ki", K, ve)
        live = self.gidx >= 0
        f.setValues(self.gidx[live].astype(PETSc.IntType), r[live], addv=PETSc.InsertMode.ADD_VALUES)
        f.assemblyBegin()
        f.assemblyEnd()

    # -- results at the interface points ----------------------------------------
    def point_values(self, x: PETSc.Vec, values: EndValues) -> dict[str, NDArray[Any]]:
        """Values at the ends (P1, P2) of every segment: where the interface crosses
        cell edges (code_aster's NFISSU points), one entry per point and cell.

        ``values(ve, phi, end)``: the law's values at the ends ``end`` (0 or 1) from
        the element values ``ve (k, nd)`` and the multiplier functions there
        ``phi (k, m)``: a dict of ``(k,)`` arrays LAGS_C, LAGS_F1, contact, sliding.

        Returns a dict of flat arrays: x, y (m), LAGS_C (Pa), LAGS_F1 (-), gap,
        slip (m, normal and tangential jump), contact (1/0), sliding (1/0), cell
        (input cell index), end (0 for P1, 1 for P2).
        """
        from xfemcontact.fem.elements import Seg3

        mesh, el, segs = self.mesh, self.mesh.element, self.segments
        assert segs is not None                  # 2-D (3-D: NodalContactProblem.facet_values)
        ve = self.element_values(x)
        nn = self.nn
        xc = mesh.x[mesh.cell_nodes[segs.cells]]
        out: dict[str, list[NDArray[Any]]] = {k: [] for k in ("x", "y", "LAGS_C", "LAGS_F1", "gap", "slip",
                                                             "contact", "sliding", "cell", "end")}
        X = el.map_points(xc, segs.nodes)                          # physical P1, P2, P3
        for end, s in ((0, -1.0), (1, 1.0)):
            xi = segs.nodes[:, end]
            N = el.shape(xi)
            pos = X[:, end]
            tan = np.einsum("a,kai->ki", Seg3.dshape(np.array(s)), X)
            n = np.stack([-tan[:, 1], tan[:, 0]], axis=1) / np.linalg.norm(tan, axis=1)[:, None]
            tau = integration.tangent_of(n)
            phi = self.space.functions(el.shape_linear(xi))
            jx = 2.0 * np.einsum("ka,ka->k", N * self.enr, ve[:, :nn])
            jy = 2.0 * np.einsum("ka,ka->k", N * self.enr, ve[:, nn:2 * nn])
            out["x"].append(pos[:, 0])
            out["y"].append(pos[:, 1])
            out["gap"].append(jx * n[:, 0] + jy * n[:, 1])
            out["slip"].append(jx * tau[:, 0] + jy * tau[:, 1])
            for key, v in values(ve, phi, end).items():
                out[key].append(v)
            out["cell"].append(mesh.cell_ids[segs.cells])
            out["end"].append(np.full(len(segs), end))
        return {k: np.concatenate(v) for k, v in out.items()}


def _dot(components: list[FloatArray], v: FloatArray) -> FloatArray:
    """sum_i components[i] v[..., i]: a vector given by its components ``(k, ng)`` each,
    dotted with unit vectors ``v (k, ng, d)``, summed in order."""
    out = components[0] * v[..., 0]
    for i in range(1, len(components)):
        out = out + components[i] * v[..., i]
    return out
