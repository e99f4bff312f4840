"""Cut cells: the interface segment and the curved sub-triangles of each side.

Everything is built in the reference coordinates ``xi`` of the parent cell
(QUAD8 or TRIA6) and mapped by the cell's own isoparametric map, so curved
cells are handled like straight ones.

For a cut cell (strictly positive and negative node values):

* its *intersection points* P1, P2 are where LN vanishes on its boundary: the
  root of the quadratic on a crossed edge, or a vertex with LN = 0 whose two
  edges in this cell have opposite signs.  Exactly two are required;
* the *interface segment* is the quadratic curve (SEG3, nodes at s = -1, +1, 0)
  through P1, P2 and P3, the point of LN = 0 on the perpendicular bisector of
  P1 P2 (found by Newton's method).  The curve and the bisector are taken in
  physical coordinates: on a cell whose map is not affine (a distorted
  quadrangle, a curved edge) a quadratic curve in ``xi`` maps to a curve that
  bends with the map, so a straight interface would come out wavy and its
  normal wrong by an amount that does not fall with h.  Points of the segment
  are therefore placed on the physical curve and pulled back to ``xi``
  (:func:`segment_curve`); on affine cells this is the same curve.  It is
  oriented with the + side (LN > 0) on its left, so its left normal is the
  interface normal n (from - to +);
* each side is the region between the cell boundary and the segment; it is cut
  into 6-node sub-triangles by a fan from P3 over the boundary path of that
  side.  The edges P3-P1 and P3-P2 of the fan triangles are the two halves of
  the segment (their mid-nodes are the segment's points at s = -1/2 and 1/2), so
  the sub-triangles tile the cell exactly and their interface edges *are* the
  contact segment.  Quadrature maps the sub-triangles' nodes to physical
  coordinates and integrates over the physical 6-node triangles (their cell-edge
  sides are exact: a cell edge is quadratic in its own coordinate).

A cell one of whose edges lies on the interface (LN = 0 at its three nodes) is
not cut; the edge is an interface segment owned by the cell on the - side.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from xfemcontact.errors import GeometryError
from xfemcontact.fem.elements import Element, Seg3, affine_cells, element
from xfemcontact.xfem.levelset import edge_crossing

if TYPE_CHECKING:
    from numpy.typing import ArrayLike, NDArray

    from xfemcontact.mesh.plex import LocalMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]

NEWTON_ITS = 50


@dataclass
class Segments:
    """Interface segments, one per owning cell, in parent reference coordinates."""

    cells: IntArray       # (k,) local cell indices
    nodes: FloatArray     # (k, 3, 2) xi of (P1, P2, P3); + side on the left of P1 -> P2
    where: IntArray       # (k, 2) local edge of P1, P2, or -1 - local vertex

    def __len__(self) -> int:
        return len(self.cells)


@dataclass
class SubCells:
    """Sub-triangles of cut cells, padded to ``ns`` per cell."""

    cells: IntArray       # (k,) local cell indices
    nodes: FloatArray     # (k, ns, 6, 2) xi of the 6 nodes of each sub-triangle
    side: IntArray        # (k, ns) -1 / +1, 0 for padding


def phi_at(el: Element, phi_cell: FloatArray, xi: FloatArray) -> FloatArray:
    """LN at reference points ``xi (k, ..., 2)`` of cells with node values ``(k, nn)``."""
    N = el.shape(xi)
    return np.einsum("k...a,ka->k...", N, phi_cell)


def grad_phi_ref(el: Element, phi_cell: FloatArray, xi: FloatArray) -> FloatArray:
    """Reference gradients ``(k, ..., 2)`` of LN at ``xi (k, ..., 2)``."""
    return np.einsum("k...ai,ka->k...i", el.dshape(xi), phi_cell)


# -- intersection points -------------------------------------------------------
def intersection_points(el: Element, phi_cell: FloatArray) -> tuple[FloatArray, IntArray, IntArray]:
    """Boundary intersection points of cut cells.

    Returns ``(xi (k, 2, 2), where (k, 2), count (k,))``; cells with a count
    other than 2 are reported by the caller.
    """
    k = len(phi_cell)
    ne = len(el.edges)
    ea, eb, em = el.edges.T
    pa, pb, pm = phi_cell[:, ea], phi_cell[:, eb], phi_cell[:, em]
    crossing = pa * pb < 0
    s = edge_crossing(pa.ravel(), pb.ravel(), pm.ravel()).reshape(k, ne)
    # vertex with LN = 0 whose two edges in this cell have opposite signs
    sign_edge = _edge_sign(pa, pb, pm)
    prev = np.roll(np.arange(ne), 1)                     # edge ending at vertex v is v-1
    vzero = (phi_cell[:, : el.nv] == 0) & (sign_edge * sign_edge[:, prev] < 0)
    cand = np.concatenate([crossing, vzero], axis=1)      # (k, ne + nv)
    count = cand.sum(axis=1)
    ref = el.ref_nodes
    s_safe = np.where(crossing, s, 0.0)
    edge_pts = 0.5 * (1 - s_safe)[..., None] * ref[ea] + 0.5 * (1 + s_safe)[..., None] * ref[eb]
    allpts = np.concatenate([edge_pts, np.broadcast_to(ref[: el.nv], (k, el.nv, 2))], axis=1)
    where_all = np.r_[np.arange(ne), -1 - np.arange(el.nv)]
    order = np.argsort(~cand, axis=1, kind="stable")[:, :2]
    xi = np.take_along_axis(allpts, order[..., None], axis=1)
    where = where_all[order]
    return xi, where, count


def _edge_sign(pa: FloatArray, pb: FloatArray, pm: FloatArray) -> FloatArray:
    """Sign of LN inside each edge that has a zero vertex (uniform after readjustment)."""
    other = np.where(pa != 0, pa, pb)
    return np.sign(np.where(pm != 0, pm, other))


def _perimeter(el: Element, where: IntArray, xi: FloatArray) -> FloatArray:
    """Perimeter coordinate t in [0, nv) of boundary points."""
    t = np.empty(where.shape)
    vert = where < 0
    t[vert] = (-1 - where[vert]).astype(float)
    edge = ~vert
    e = where[edge]
    a = el.ref_nodes[el.edges[e, 0]]
    b = el.ref_nodes[el.edges[e, 1]]
    frac = np.linalg.norm(xi[edge] - a, axis=-1) / np.linalg.norm(b - a, axis=-1)
    t[edge] = e + frac
    return t


# -- the segment ---------------------------------------------------------------
def segment_midpoints(el: Element, phi_cell: FloatArray, xc: FloatArray, p1: FloatArray,
                      p2: FloatArray, cell_ids: IntArray) -> FloatArray:
    """P3: LN = 0 on the perpendicular bisector of P1 P2 in physical coordinates
    (cells ``xc (k, nn, 2)``); reference coordinates ``(k, 2)``.  Where that point
    is not found inside the cell (a badly distorted cell), the zero of LN on the
    reference bisector is kept: still a point of the interface, only less central."""
    mid = 0.5 * (p1 + p2)
    chord = p2 - p1
    d = np.stack([-chord[:, 1], chord[:, 0]], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    t = np.zeros(len(mid))
    half = 0.5 * np.linalg.norm(chord, axis=-1)
    for _ in range(NEWTON_ITS):
        x = mid + t[:, None] * d
        f = phi_at(el, phi_cell, x)
        df = np.einsum("ki,ki->k", grad_phi_ref(el, phi_cell, x), d)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.clip(np.where(df != 0, f / df, 0.0), -half, half)
        t -= step
        if np.all(np.abs(step) <= 1e-15 * (1 + np.abs(t))):
            break
    p3_ref = mid + t[:, None] * d
    scale = np.abs(phi_cell).max(axis=1)

    def off(p: FloatArray) -> BoolArray:
        return ~(np.abs(phi_at(el, phi_cell, p)) <= 1e-10 * scale) | ~el.contains(p, 1e-9)

    p3 = _physical_bisector(el, phi_cell, xc, p1, p2, p3_ref)
    p3 = np.where(off(p3)[:, None], p3_ref, p3)
    bad = off(p3)
    if bad.any():
        c = int(np.nonzero(bad)[0][0])
        raise GeometryError(f"level set: cannot place the interface inside cell {cell_ids[c]} "
                            f"(no zero of LN on the bisector of its intersection points): refine the mesh there")
    return p3


def _physical_bisector(el: Element, phi_cell: FloatArray, xc: FloatArray, p1: FloatArray,
                       p2: FloatArray, xi: FloatArray) -> FloatArray:
    """Newton from ``xi`` on LN(xi) = 0, (x(xi) - m) . c = 0 with m, c the midpoint
    and chord of the physical P1 P2.  The reference bisector's point (``xi``) is
    already the answer on cells whose map is a similarity; elsewhere it is a few
    steps away."""
    x12 = el.map_points(xc, np.stack([p1, p2], axis=1))
    m = 0.5 * (x12[:, 0] + x12[:, 1])
    c = x12[:, 1] - x12[:, 0]
    xi = xi.copy()
    active = np.ones(len(xi), bool)
    for _ in range(NEWTON_ITS):
        idx = np.nonzero(active)[0]
        if len(idx) == 0:
            break
        N, dN = el.shape(xi[idx]), el.dshape(xi[idx])
        f = np.stack([np.einsum("ka,ka->k", N, phi_cell[idx]),
                      np.einsum("ka,kai,ki->k", N, xc[idx], c[idx]) - np.einsum("ki,ki->k", m[idx], c[idx])], 1)
        J = np.stack([np.einsum("kaj,ka->kj", dN, phi_cell[idx]),
                      np.einsum("kaj,kai,ki->kj", dN, xc[idx], c[idx])], axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.linalg.solve(J, f[..., None])[..., 0]
        ok = np.isfinite(step).all(axis=1)
        step = np.where(ok[:, None], np.clip(step, -0.5, 0.5), 0.0)
        xi[idx] -= step
        active[idx[~ok | (np.abs(step).max(axis=1) <= 1e-15 * (1 + np.abs(xi[idx]).max(axis=1)))]] = False
    return xi


def segment_curve(el: Element, xc: FloatArray, nodes: FloatArray, s: ArrayLike,
                  cell_ids: IntArray | None = None) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Points of segments with reference nodes ``nodes (k, 3, 2)`` at abscissae ``s (p,)``.

    The segment is the quadratic curve through the physical images of its nodes.
    Returns ``xi (k, p, 2)`` (pulled back by Newton; on affine cells the quadratic
    curve of the reference nodes), ``x (k, p, 2)`` and ``dx/ds (k, p, 2)`` (m).
    ``cell_ids (k,)`` name the cells in errors.
    """
    s = np.asarray(s, dtype=float)
    S, dS = Seg3.shape(s), Seg3.dshape(s)                                      # (p, 3)
    X = el.map_points(xc, nodes)                                               # (k, 3, 2)
    x = np.einsum("pa,kai->kpi", S, X)
    # on affine cells the quadratic curve of the reference nodes is the pull-back already
    live = np.broadcast_to(~affine_cells(el, xc)[:, None], x.shape[:2])
    xi, failed = el.inverse_map(xc, x, np.einsum("pa,kai->kpi", S, nodes), live)
    if failed.any():
        raise not_invertible(failed, cell_ids)
    return xi, x, np.einsum("pa,kai->kpi", dS, X)


def not_invertible(failed: BoolArray, cell_ids: IntArray | None = None) -> GeometryError:
    """The error for cells ``failed (k,)`` whose map could not be inverted at an interface
    or sub-cell point (a cell so distorted that Newton's method does not converge)."""
    c = int(np.nonzero(failed)[0][0])
    name = f"cell {cell_ids[c]}" if cell_ids is not None else "a cut cell"
    return GeometryError(f"level set: cannot map the interface into {name} (the cell is too "
                         f"distorted for its quadratic map to be inverted): refine the mesh there")


def orient(el: Element, phi_cell: FloatArray, xi: FloatArray,
           where: IntArray) -> tuple[FloatArray, IntArray]:
    """Order P1, P2 so that the + side is on the left of P1 -> P2."""
    p1, p2 = xi[:, 0], xi[:, 1]
    g = grad_phi_ref(el, phi_cell, 0.5 * (p1 + p2))
    chord = p2 - p1
    left = np.stack([-chord[:, 1], chord[:, 0]], axis=-1)
    swap = np.einsum("ki,ki->k", left, g) < 0
    xi = np.where(swap[:, None, None], xi[:, ::-1], xi)
    where = np.where(swap[:, None], where[:, ::-1], where)
    return xi, where


# -- sub-triangles -------------------------------------------------------------
def _side_paths(el: Element, t1: FloatArray, t2: FloatArray) -> tuple[IntArray, IntArray]:
    """Boundary corners of each side, in walking order.

    Minus side: from P1 counter-clockwise to P2; plus side: from P2 to P1.
    Returns two ``(k, nv)`` arrays of corner indices (-1 padding).
    """
    nv = el.nv
    corners = np.arange(nv)[None, :]

    def between(ts: FloatArray, te: FloatArray) -> IntArray:
        span = np.mod(te - ts, nv)[:, None]
        off = np.mod(corners - ts[:, None], nv)
        inside = (off > 1e-12) & (off < span - 1e-12)
        key = np.where(inside, off, np.inf)
        order = np.argsort(key, axis=1, kind="stable")
        return np.where(np.take_along_axis(inside, order, axis=1), order, -1)

    return between(t1, t2), between(t2, t1)


def _ring(el: Element, seg: FloatArray, halves: FloatArray, path_corners: IntArray,
          start: FloatArray, end: FloatArray, s_start: float,
          s_end: float) -> tuple[FloatArray, FloatArray, IntArray]:
    """The boundary ring of one side: start, corners..., end, P3.

    Returns points ``(k, L, 2)``, the mid-point of each ring edge ``(k, L, 2)``
    (edge e joins point e and e+1; the last two edges are the halves of the
    segment, curved) and the ring length ``L (k,)``.
    """
    k, nv = path_corners.shape
    ref = el.ref_nodes
    ncorner = (path_corners >= 0).sum(axis=1)
    L = ncorner + 3
    Lmax = nv + 3
    rows = np.arange(k)
    pts = np.zeros((k, Lmax, 2))
    pts[:, 0] = start
    pts[:, 1:nv + 1] = ref[np.maximum(path_corners, 0)]
    pts[rows, L - 2] = end
    pts[rows, L - 1] = seg[:, 2]
    # a side without corners (the interface leaves and meets the same straight
    # edge) is a lens: split it at the midpoint of that edge, else the fan
    # triangle would have a flat angle at P3
    lens = ncorner == 0
    if lens.any():
        L = np.where(lens, 4, L)
        pts[lens, 1] = 0.5 * (start[lens] + end[lens])
        pts[lens, 2] = end[lens]
        pts[lens, 3] = seg[lens, 2]
    nxt = np.where(np.arange(Lmax)[None, :] + 1 < L[:, None], np.arange(Lmax)[None, :] + 1, 0)
    mids = 0.5 * (pts + np.take_along_axis(pts, nxt[..., None], axis=1))
    mids[rows, L - 2] = halves[:, int(s_end > 0)]           # end -> P3
    mids[rows, L - 1] = halves[:, int(s_start > 0)]         # P3 -> start
    return pts, mids, L


def _fans(pts: FloatArray, mids: FloatArray, L: IntArray) -> tuple[FloatArray, BoolArray]:
    """Every fan triangulation of the rings: ``(k, C, T, 6, 2)`` and validity ``(k, C, T)``.

    Fan ``c`` joins ring point c to every ring edge not incident to it; its
    diagonals are straight, ring edges keep their (possibly curved) mid-points.
    """
    k, Lmax, _ = pts.shape
    T = Lmax - 2
    c = np.arange(Lmax)[:, None]
    d = np.arange(1, T + 1)[None, :]
    Lk = L[:, None, None]
    ia = np.broadcast_to(c, (Lmax, T))[None] % Lk
    ib = (c + d)[None] % Lk
    ic = (c + d + 1)[None] % Lk
    valid = (c[None] < Lk) & (d[None] <= Lk - 2)
    rows = np.arange(k)[:, None, None]

    def take(arr: FloatArray, idx: IntArray) -> FloatArray:
        return arr[rows, idx]

    A, B, C = take(pts, ia), take(pts, ib), take(pts, ic)
    mid_ab = np.where((d == 1)[None, ..., None], take(mids, ia), 0.5 * (A + B))
    mid_bc = take(mids, ib)
    mid_ca = np.where((d + 1 == Lk - 1)[..., None], take(mids, ic), 0.5 * (C + A))
    tri = np.stack([A, B, C, mid_ab, mid_bc, mid_ca], axis=3)
    return tri, valid


#: fans whose qualities differ by less than this are equally good: the first one in
#: ring order is taken, so that round-off (a cell numbered from another vertex on
#: another process) does not change the choice
FAN_TIE = 1e-9


def _best_fan(tri: FloatArray, valid: BoolArray) -> tuple[FloatArray, BoolArray, FloatArray]:
    """Pick, per cell, the fan whose worst sub-triangle is the least distorted
    (the first in ring order among those within ``FAN_TIE`` of the best)."""
    zeta = TRI6.check_points
    k, C, T = valid.shape
    det = subcell_jacobians(tri.reshape(k, C * T, 6, 2), zeta).reshape(k, C, T, -1)
    area = np.abs(det).max(axis=3)
    quality = np.where(valid, det.min(axis=3) / np.maximum(area, 1e-300), np.inf).min(axis=2)
    quality[~valid.any(axis=2)] = -np.inf
    top = quality.max(axis=1, keepdims=True)
    best = np.argmax(quality >= top - FAN_TIE * np.abs(top), axis=1)
    rows = np.arange(k)
    return tri[rows, best], valid[rows, best], quality[rows, best]


def subcells(el: Element, seg: FloatArray, where: IntArray,
             halves: FloatArray) -> tuple[FloatArray, IntArray, FloatArray]:
    """Sub-triangles of both sides of cut cells with segments ``seg (k, 3, 2)``;
    ``halves (k, 2, 2)``: the segments' points at s = -1/2 and +1/2 (mid-nodes of
    the fan triangles' interface edges).

    Returns ``(nodes (k, ns, 6, 2), side (k, ns), quality (k,))``.
    """
    t = _perimeter(el, where, seg[:, :2])
    minus_c, plus_c = _side_paths(el, t[:, 0], t[:, 1])
    parts, sides, quality = [], [], []
    for corners, a, b, sa, sb, sgn in ((minus_c, seg[:, 0], seg[:, 1], -1.0, 1.0, -1),
                                       (plus_c, seg[:, 1], seg[:, 0], 1.0, -1.0, 1)):
        tri, valid = _fans(*_ring(el, seg, halves, corners, a, b, sa, sb))
        nodes, ok, q = _best_fan(tri, valid)
        parts.append(nodes)
        sides.append(np.where(ok, sgn, 0))
        quality.append(q)
    return np.concatenate(parts, axis=1), np.concatenate(sides, axis=1), np.minimum(*quality)


TRI6 = element("TRIA6")


def subcell_jacobians(nodes: FloatArray, zeta: FloatArray) -> FloatArray:
    """det of the maps reference triangle -> parent reference coordinates at ``zeta``:
    ``nodes (..., 6, 2)`` -> ``(..., q)``."""
    J = np.tensordot(nodes, TRI6.dshape(zeta), axes=([-2], [1]))             # (..., 2, q, 2), one BLAS call
    return J[..., 0, :, 0] * J[..., 1, :, 1] - J[..., 0, :, 1] * J[..., 1, :, 0]


#: largest reference area, as a fraction of the parent cell's, on which a
#: sub-triangle's Jacobian may be negative
FOLD_AREA = 1e-4


def _lattice(m: int) -> FloatArray:
    """Centroids of the m^2 sub-triangles of the reference triangle split m times per side."""
    i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    up = np.stack([i + 1 / 3, j + 1 / 3], axis=-1)[i + j <= m - 1]
    down = np.stack([i + 2 / 3, j + 2 / 3], axis=-1)[i + j <= m - 2]
    return np.r_[up, down] / m


def folded_area(nodes: FloatArray, m: int = 24) -> tuple[FloatArray, FloatArray]:
    """Reference areas (parent coordinates) of sub-triangles ``nodes (..., 6, 2)``:
    ``(signed, folded)``, the integral of det and of max(-det, 0), each ``(...)``,
    estimated on the centroids of an ``m x m`` split of the reference triangle."""
    zeta = _lattice(m)
    det = subcell_jacobians(nodes, zeta) * (0.5 / len(zeta))
    return det.sum(axis=-1), -np.minimum(det, 0.0).sum(axis=-1)


def invalid_subcells(nodes: FloatArray, side: IntArray, parent_area: float) -> BoolArray:
    """Cells whose sub-triangles do not map one-to-one: ``(k,)`` bool.

    A sub-triangle of zero area (three points on one straight edge, when the
    interface is tangent to it at P3) is dropped (its ``side`` set to 0).  An
    interface tangent to a cell edge at a node leaves a sliver whose curved side,
    the quadratic segment, crosses the straight edge by O(h^3) near the tangency:
    the map folds there.  Integrals with the signed Jacobian remain those over
    the side (its boundary still winds once), so such a fold is accepted when its
    area is below ``FOLD_AREA`` of the cell.
    """
    zeta = TRI6.check_points
    det = subcell_jacobians(nodes, zeta)
    area = np.abs(det).max(axis=2)
    flat = (side != 0) & (area <= 1e-12 * parent_area)
    side[flat] = 0
    bad = (side != 0) & ~np.all(det > 1e-12 * np.maximum(area, 1e-300)[..., None], axis=2)
    if bad.any():
        c, s = np.nonzero(bad)
        signed, fold = folded_area(nodes[c, s])
        ok = (fold <= FOLD_AREA * parent_area) & (signed > fold)
        bad[c[ok], s[ok]] = False
    return bad.any(axis=1)


def too_curved(cell_id: int) -> GeometryError:
    """The error for a cut cell whose sub-cells cannot follow the interface."""
    return GeometryError(f"level set: the interface is too curved in cell {cell_id} to be "
                         f"followed by quadratic sub-cells: refine the mesh there")


# -- driver ----------------------------------------------------------------------
def cut_cells(mesh: LocalMesh, phi: FloatArray,
              side: IntArray) -> tuple[Segments, SubCells, BoolArray]:
    """Segments and sub-cells of the cut cells (``side == 0``), and the mask
    ``(k,)`` of those whose sub-cells are invalid (:func:`invalid_subcells`)."""
    el = mesh.element
    cells = np.nonzero(side == 0)[0]
    if len(cells) == 0:
        return (Segments(cells, np.zeros((0, 3, 2)), np.zeros((0, 2), np.int64)),
                SubCells(cells, np.zeros((0, 2 * (el.nv + 1), 6, 2)), np.zeros((0, 2 * (el.nv + 1)), np.int64)),
                np.zeros(0, bool))
    phi_cell = phi[mesh.cell_nodes[cells]]
    xi, where, count = intersection_points(el, phi_cell)
    if np.any(count != 2):
        c = cells[np.nonzero(count != 2)[0][0]]
        ctr = mesh.x[mesh.cell_nodes[c]].mean(0)
        raise GeometryError(f"level set: the interface crosses the boundary of cell {mesh.cell_ids[c]} "
                            f"near ({ctr[0]:.6g}, {ctr[1]:.6g}) {count[np.nonzero(count != 2)[0][0]]} times "
                            f"(2 expected): refine the mesh there")
    xi, where = orient(el, phi_cell, xi, where)
    xc = mesh.x[mesh.cell_nodes[cells]]
    p3 = segment_midpoints(el, phi_cell, xc, xi[:, 0], xi[:, 1], mesh.cell_ids[cells])
    seg = np.concatenate([xi, p3[:, None]], axis=1)
    halves = segment_curve(el, xc, seg, [-0.5, 0.5], mesh.cell_ids[cells])[0]
    nodes, sub_side, _ = subcells(el, seg, where, halves)
    bad = invalid_subcells(nodes, sub_side, 1.0 / el.ref_area_inv)
    return Segments(cells, seg, where), SubCells(cells, nodes, sub_side), bad


def edge_segments(mesh: LocalMesh, phi: FloatArray, side: IntArray) -> Segments:
    """Interface segments lying on cell edges (LN = 0 at the edge's three nodes).

    Each interior such edge is owned by its cell on the - side; edges on the
    domain boundary are not interfaces.
    """
    el = mesh.element
    on = np.all(phi[mesh.cell_nodes[:, el.edges]] == 0, axis=2)      # (nc, ne)
    owner = on & (side == -1)[:, None]
    cells, edges = np.nonzero(owner)
    if len(cells) == 0:
        return Segments(cells, np.zeros((0, 3, 2)), np.zeros((0, 2), int))
    # drop domain-boundary edges
    bnd = _boundary_mid_nodes(mesh)
    mids = mesh.cell_nodes[cells, el.edges[edges, 2]]
    keep = ~np.isin(mids, bnd)
    cells, edges = cells[keep], edges[keep]
    ref = el.ref_nodes
    a, b, m = el.edges[edges].T
    # the cell is on the - side, the + side is outside: walk the edge clockwise
    nodes = np.stack([ref[b], ref[a], ref[m]], axis=1)
    where = np.stack([-1 - b, -1 - a], axis=1)
    return Segments(cells, nodes, where)


def _boundary_mid_nodes(mesh: LocalMesh) -> IntArray:
    be = mesh.boundary_edges()
    return be[:, 2] if len(be) else np.zeros(0, dtype=np.int64)
