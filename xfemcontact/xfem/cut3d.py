"""Cut 3-D cells (HEXA20, TETRA10): curved sub-tetrahedra of both sides and the
curved interface triangles between them.

Method (everything in the parent cell's reference coordinates ``xi``, where LN
is the cell's own P2 / serendipity interpolant of its node values):

1. The parent is split into reference tetrahedra: TETRA10 is one, HEXA20 the six
   tetrahedra around the diagonal from vertex 1 to vertex 7 (:func:`parent_tets`).
   Their vertices are parent vertices, whose LN values are node values.
2. Each tetrahedron is cut by the signs of LN at its vertices
   (:mod:`xfemcontact.xfem.tet_tables`, marching tetrahedra): its edges with a sign
   change get the point where the parent's LN vanishes along them (a safeguarded
   Newton on the polynomial along the straight reference segment: the SEG3
   quadratic on the parent's edges, a cubic or quartic on HEXA20's diagonals); the
   tables give the sub-tetrahedra of each side and the one or two interface
   triangles, all with straight edges between these points.
3. Each straight edge joining two interface points gets its mid-node moved onto the
   zero set of LN (:func:`project_midpoints`): from the edge's midpoint along the
   reference gradient of LN, made orthogonal to the edge and, when the two points lie
   on a common face of the tetrahedron, kept in that face's plane (so the sub-cells
   still tile each tetrahedron and the parent exactly).  Every other edge keeps its
   midpoint.  Sub-tetrahedra are then TETRA10 maps ``zeta -> xi`` and interface
   facets TRIA6 maps ``eta -> xi``; the facets are faces of the sub-tetrahedra.

Why this method: on an affine cell with a planar cut (LN linear), the edge points
are exact, every projected mid-node is the midpoint (LN already vanishes there),
so the sub-cells are straight and tile each side exactly: a Gauss rule of the
integrand's degree on each sub-tetrahedron integrates polynomials exactly, and
volumes, areas and normals are exact to round-off.  On curved interfaces the
facets interpolate the zero set quadratically (interpolation points on the
surface), so sides and interface converge at the order of isoparametric P2
geometry (volumes and areas O(h^3) or better; README gives the measured orders),
with no tolerance-driven recursion, no moment fitting and a fixed number of
sub-cells per cell, which keeps every step a NumPy operation over batches of
cells (loops only over the few table topologies and Newton iterations).  The
physical quadrature composes the two maps (sub-cell -> ``xi`` -> ``x``), so a
curved or non-affine parent is tiled exactly too.

Degenerate positions.  A vertex with LN = 0 counts as + (the tables' rule): the
pieces that collapse onto it have zero measure and zero weights.  A face of the
parent with LN = 0 at all its nodes is an interface face, handled by the caller
(the cell on the - side is not cut).  A thin sub-tetrahedron under a strongly
curved facet may fold (its Jacobian changes sign): the sub-cells share their
faces node for node, so they form a chain whose boundary is the side's boundary
and the signed Jacobians still integrate over the side (:func:`negative_sides`);
:func:`folded` counts them.  Where the interface passes within a small fraction
of the cell from a vertex (but farther than the readjustment's 1e-6), an
interface quadrangle may lie nearly flat against a face and the zero set of its
diagonal lie outside the tetrahedron: that mid-node stops on the tetrahedron's
boundary (the facet is then locally flatter than the interface, an O(h^2 k)
deviation on a few facets) and is counted.  A side of negative volume (facets
leaving their tetrahedron) is reported per cell (``bad``) so the caller can ask
for a finer mesh.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations
from typing import TYPE_CHECKING

import numpy as np

from xfemcontact.fem.elements import Element, determinants, element
from xfemcontact.xfem import tet_tables as tt

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]

NEWTON_ITS = 60

TETRA10 = element("TETRA10")
TRIA6 = element("TRIA6")


@dataclass
class SubTets:
    """Curved sub-tetrahedra of cut cells, padded to ``ns`` per cell."""

    cells: IntArray       # (k,) local cell indices
    nodes: FloatArray     # (k, ns, 10, 3) parent xi of the TETRA10 nodes of each sub-cell
    side: IntArray        # (k, ns) -1 / +1, 0 for padding


@dataclass
class Facets:
    """Curved interface triangles of cut cells, padded to ``nf`` per cell; the
    right-hand normal of (node 0, 1, 2) points from - (LN < 0) to + (LN > 0)."""

    cells: IntArray       # (k,) local cell indices
    nodes: FloatArray     # (k, nf, 6, 3) parent xi of the TRIA6 nodes of each facet
    live: BoolArray       # (k, nf) False for padding

    def __len__(self) -> int:
        return len(self.cells)


def parent_tets(el: Element) -> IntArray:
    """Parent vertices ``(nt, 4)`` of the reference tetrahedra of ``el``, each with a
    positive orientation in ``xi`` (``det[v1 - v0, v2 - v0, v3 - v0] > 0``)."""
    X = el.ref_nodes[: el.nv]
    if el.name == "TETRA10":
        tets = [[0, 1, 2, 3]]
    elif el.name == "HEXA20":
        tets = []
        start = int(np.nonzero((X == -1).all(axis=1))[0][0])
        for order in permutations(range(3)):              # Kuhn: paths (-1,-1,-1) -> (1,1,1)
            path = [X[start]]
            for axis in order:
                path.append(path[-1] + 2 * np.eye(3)[axis])
            tets.append([int(np.nonzero((X == p).all(axis=1))[0][0]) for p in path])
    else:
        raise ValueError(f"{el.name} is not a 3-D cell")
    out = np.array(tets)
    v = X[out]
    neg = np.linalg.det(np.swapaxes(v[:, 1:] - v[:, :1], 1, 2)) < 0
    out[neg] = out[neg][:, [0, 2, 1, 3]]
    return out


def phi_at(el: Element, phi_cell: FloatArray, xi: FloatArray) -> FloatArray:
    """LN at reference points ``xi (k, ..., 3)`` of cells with node values ``(k, nn)``."""
    return np.einsum("k...a,ka->k...", el.shape(xi), phi_cell)


def grad_phi(el: Element, phi_cell: FloatArray, xi: FloatArray) -> FloatArray:
    """Reference gradients ``(k, ..., 3)`` of LN at ``xi (k, ..., 3)``."""
    return np.einsum("k...ai,ka->k...i", el.dshape(xi), phi_cell)


def segment_roots(el: Element, phi_cell: FloatArray, xa: FloatArray, xb: FloatArray,
                  fa: FloatArray, fb: FloatArray) -> FloatArray:
    """Where LN vanishes on the reference segments ``xa -> xb`` (each ``(k, m, 3)``) whose
    end values ``fa``, ``fb (k, m)`` lie on opposite sides (LN >= 0 counting as +):
    the parameter ``t (k, m)`` in [0, 1] (0 where ``fa == 0``, 1 where ``fb == 0``,
    0.5 on segments without a sign change).

    Newton's method kept inside a shrinking bracket (bisection where a step leaves
    it), so a root is always returned; on a straight LN it is exact after one step.
    """
    k, m = fa.shape
    sgn = np.where(fa < 0, 1.0, -1.0)                 # g = sgn LN: g(0) < 0 <= g(1)
    crossing = (fa >= 0) != (fb >= 0)
    active = crossing & (fa != 0) & (fb != 0)
    t = np.where(fa == 0, 0.0, np.where(fb == 0, 1.0, 0.5))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(active, fa / (fa - fb), t)
    lo, hi = np.zeros((k, m)), np.ones((k, m))
    d = xb - xa
    cell = np.broadcast_to(np.arange(k)[:, None], (k, m))
    for _ in range(NEWTON_ITS):
        idx = np.nonzero(active)
        if len(idx[0]) == 0:
            break
        x = xa[idx] + t[idx][:, None] * d[idx]
        pc = phi_cell[cell[idx]]
        g = sgn[idx] * np.einsum("ma,ma->m", el.shape(x), pc)
        dg = sgn[idx] * np.einsum("mai,ma,mi->m", el.dshape(x), pc, d[idx])
        lo[idx] = np.where(g < 0, t[idx], lo[idx])
        hi[idx] = np.where(g >= 0, t[idx], hi[idx])
        with np.errstate(divide="ignore", invalid="ignore"):
            new = t[idx] - g / dg
        inside = np.isfinite(new) & (new > lo[idx]) & (new < hi[idx])
        new = np.where(inside, new, 0.5 * (lo[idx] + hi[idx]))
        done = (g == 0) | (np.abs(new - t[idx]) <= 1e-15) | (hi[idx] - lo[idx] <= 1e-15)
        t[idx] = np.where(g == 0, t[idx], new)
        sub = tuple(i[done] for i in idx)
        active[sub] = False
    return t


def project_midpoints(el: Element, phi_cell: FloatArray, pa: FloatArray, pb: FloatArray,
                      face_normal: FloatArray, tet: FloatArray,
                      xc: FloatArray | None = None) -> tuple[FloatArray, BoolArray]:
    """Mid-nodes ``(k, m, 3)`` on LN = 0 of the straight edges ``pa -> pb`` (``(k, m, 3)``,
    both ends on LN = 0) of tetrahedra ``tet (k, m, 4, 3)``, and whether each was left
    off the zero set ``(k, m)``.

    The search line starts at the midpoint and follows the reference gradient of LN,
    minus its components along the edge and along ``face_normal (k, m, 3)`` (zero
    vector: no face constraint), so the node stays in the face's plane.  Newton's
    method on LN along the line is kept inside the tetrahedron: where the zero lies
    beyond its boundary (an interface passing within a small fraction of the cell from
    a vertex, whose quadrangle is nearly flat against a face), the node stops on the
    boundary, the nearest point of the line to the zero set inside the tetrahedron, so
    the sub-cells still tile it; such nodes are reported.

    With the cells' node coordinates ``xc (k, nn, 3)`` (m), an edge on a face takes its
    search direction in physical space: the physical gradient of LN minus its components
    along the face's physical normal and the edge, mapped back to reference coordinates.
    That direction depends only on the face (its map and LN's values on it), so the two
    cells sharing a face put the node at the same point and the interface joins up
    across it; in each cell's reference coordinates the two searches differed wherever
    the cells' maps are no similarity (TETRA10 boxes: a cap's rim on a face was followed
    at 81.9 degrees of a quarter circle by one cell and elsewhere by its neighbour).
    """
    k, m, _ = pa.shape
    mid = 0.5 * (pa + pb)
    c = pb - pa

    g = grad_phi(el, phi_cell, mid)
    for u in (_unit(face_normal), _unit(c)):
        g = g - np.einsum("kmi,kmi->km", g, u)[..., None] * u
    d = _unit(g)
    on_face = np.abs(face_normal).sum(axis=-1) > 0
    if xc is not None and on_face.any():
        d = np.where(on_face[..., None], _physical_direction(el, phi_cell, xc, mid, c, face_normal), d)
    tmin, tmax = _line_in_tet(tet, mid, d)
    t = np.zeros((k, m))
    active = (np.linalg.norm(c, axis=-1) > 0) & (np.abs(d).sum(axis=-1) > 0)
    cell = np.broadcast_to(np.arange(k)[:, None], (k, m))
    for _ in range(NEWTON_ITS):
        idx = np.nonzero(active)
        if len(idx[0]) == 0:
            break
        x = mid[idx] + t[idx][:, None] * d[idx]
        pc = phi_cell[cell[idx]]
        f = np.einsum("ma,ma->m", el.shape(x), pc)
        df = np.einsum("mai,ma,mi->m", el.dshape(x), pc, d[idx])
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(df != 0, f / df, 0.0)
        new = np.clip(t[idx] - step, tmin[idx], tmax[idx])
        done = (f == 0) | ~np.isfinite(new) | (np.abs(new - t[idx]) <= 1e-15 * (1 + np.abs(t[idx])))
        t[idx] = np.where(np.isfinite(new), new, t[idx])
        active[tuple(i[done] for i in idx)] = False
    p = mid + t[..., None] * d
    scale = np.abs(phi_cell).max(axis=1)[:, None]
    off = ~(np.abs(phi_at(el, phi_cell, p)) <= 1e-10 * scale)
    return p, off


def _unit(v: FloatArray) -> FloatArray:
    """Unit vectors along the last axis of ``v`` (zero where ``v`` is)."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 0, v / np.where(n > 0, n, 1.0), 0.0)


def _physical_direction(el: Element, phi_cell: FloatArray, xc: FloatArray, mid: FloatArray,
                        c: FloatArray, face_normal: FloatArray) -> FloatArray:
    """Reference directions ``(k, m, 3)`` of :func:`project_midpoints`' search for edges on
    faces, from physical space (``xc (k, nn, 3)`` the cells' nodes, ``mid``, ``c``,
    ``face_normal`` in reference coordinates, each ``(k, m, 3)``)."""
    J = np.einsum("kai,kmaj->kmij", xc, el.dshape(mid))             # dx / dxi at the midpoints
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.linalg.solve(np.swapaxes(J, -1, -2), grad_phi(el, phi_cell, mid)[..., None])[..., 0]
        n = np.linalg.solve(np.swapaxes(J, -1, -2), face_normal[..., None])[..., 0]   # covariant
        e = np.einsum("kmij,kmj->kmi", J, c)                                          # tangent

    n = _unit(n)
    e = _unit(e - np.einsum("kmi,kmi->km", e, n)[..., None] * n)
    for u in (n, e):
        g = g - np.einsum("kmi,kmi->km", g, u)[..., None] * u
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.linalg.solve(J, _unit(g)[..., None])[..., 0]
    return np.where(np.isfinite(d), _unit(d), 0.0)


def _line_in_tet(tet: FloatArray, p: FloatArray, d: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Parameters ``(tmin, tmax)`` (each ``(k, m)``, tmin <= 0 <= tmax) of the part of the
    lines ``p + t d`` inside tetrahedra ``tet (k, m, 4, 3)``; ``p`` lies in (or on) them."""
    A = np.swapaxes(tet[..., 1:, :] - tet[..., :1, :], -1, -2)            # (k, m, 3, 3)
    Ainv = np.linalg.inv(A)
    lam = np.einsum("kmij,kmj->kmi", Ainv, p - tet[..., 0, :])
    lam = np.concatenate([1 - lam.sum(axis=-1, keepdims=True), lam], axis=-1)   # (k, m, 4)
    dl = np.einsum("kmij,kmj->kmi", Ainv, d)
    dl = np.concatenate([-dl.sum(axis=-1, keepdims=True), dl], axis=-1)
    lam = np.maximum(lam, 0.0)
    moving = np.abs(dl) > 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = np.where(moving, -lam / np.where(moving, dl, 1.0), np.nan)
    tmax = np.where(moving & (dl < 0), bound, np.inf).min(axis=-1)
    tmin = np.where(moving & (dl > 0), bound, -np.inf).max(axis=-1)
    return np.minimum(tmin, 0.0), np.maximum(tmax, 0.0)


def quad_diagonals(el: Element, phi_cell: FloatArray, P: FloatArray, V: FloatArray,
                   pattern: IntArray) -> IntArray:
    """For tetrahedra ``V (k, T, 4, 3)`` cut two against two, the diagonal (0: q0 q2,
    1: q1 q3, see :data:`tet_tables.QUADS`) of the interface quadrangle whose mid-node
    lands closer to the zero set (:func:`project_midpoints`; on a tie, the one that moves
    less: the flatter split); 0 elsewhere.  ``P (k, T, 10, 3)``: the points of the
    tetrahedra, ``pattern (k, T)``."""
    q = tt.QUADS[pattern]                                      # (k, T, 4)
    quad = q[..., 0] >= 0
    out = np.zeros(pattern.shape, np.int64)
    rows = np.nonzero(quad.any(axis=1))[0]
    if len(rows) == 0:
        return out
    r, T = len(rows), pattern.shape[1]
    Q = _take(P[rows], q[rows])                                # (r, T, 4, 3)
    a, b = Q[..., :2, :], Q[..., 2:, :]                        # diagonals q0 q2, q1 q3
    tet = np.broadcast_to(V[rows][:, :, None], (r, T, 2, 4, 3)).reshape(r, -1, 4, 3)
    pc = phi_cell[rows]
    p, _ = project_midpoints(el, pc, a.reshape(r, -1, 3), b.reshape(r, -1, 3), np.zeros((r, 2 * T, 3)), tet)
    f = np.abs(phi_at(el, pc, p))
    g = np.linalg.norm(grad_phi(el, pc, p), axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        dist = np.where(g > 0, f / g, np.where(f > 0, np.inf, 0.0)).reshape(r, T, 2)
    move = np.linalg.norm(p - 0.5 * (a + b).reshape(r, -1, 3), axis=-1).reshape(r, T, 2)
    tol = 1e-12 * np.linalg.norm(a - b, axis=-1).max(axis=-1)
    second = (dist[..., 1] < dist[..., 0] - tol) | ((np.abs(dist[..., 1] - dist[..., 0]) <= tol)
                                                     & (move[..., 1] < move[..., 0]))
    out[rows] = np.where(quad[rows] & second, 1, 0)
    return out


def _take(points: FloatArray, index: IntArray) -> FloatArray:
    """``points (k, t, p, 3)`` at ``index (k, t, ...)`` along axis 2 (-1 -> point 0)."""
    k, t = index.shape[:2]
    flat = np.maximum(index, 0).reshape(k, t, -1)
    out = np.take_along_axis(points, flat[..., None], axis=2)
    return out.reshape(index.shape + (3,))


def cut_cells(el: Element, phi_cell: FloatArray, cells: IntArray | None = None,
              xc: FloatArray | None = None) -> tuple[SubTets, Facets, BoolArray, IntArray]:
    """Sub-tetrahedra and interface facets of cut cells with node values ``phi_cell (k, nn)``.

    ``cells (k,)`` are stored in the results (default ``arange(k)``); ``xc (k, nn, 3)``: the
    cells' node coordinates (m), which make the mid-nodes of interface edges on faces
    agree between neighbours (:func:`project_midpoints`).  Returns
    ``(SubTets, Facets, bad (k,), off (k,))``; ``bad`` marks cells whose sub-cells
    cannot follow the interface (see the module documentation), ``off`` counts the
    interface edges whose mid-node stayed off the zero set (:func:`project_midpoints`).
    Padding is trimmed to the largest number of live sub-cells and facets of the batch.
    """
    k = len(phi_cell)
    cells = np.arange(k) if cells is None else np.asarray(cells)
    if k == 0:
        return (SubTets(cells, np.zeros((0, 1, 10, 3)), np.zeros((0, 1), np.int64)),
                Facets(cells, np.zeros((0, 1, 6, 3)), np.zeros((0, 1), bool)),
                np.zeros(0, bool), np.zeros(0, np.int64))
    tets = parent_tets(el)                                     # (T, 4)
    V = np.broadcast_to(el.ref_nodes[tets], (k, len(tets), 4, 3))    # tetrahedron vertices, xi
    pv = phi_cell[:, tets]                                     # (k, T, 4)
    V, pv, tlive = split_double_crossings(el, phi_cell, V, pv)
    T = V.shape[1]
    pattern = ((pv >= 0) << np.arange(4)).sum(axis=-1)         # (k, T)
    # edge points
    ea, eb = tt.TET_EDGES.T
    fa, fb = pv[..., ea], pv[..., eb]                          # (k, T, 6)
    crossing = (fa >= 0) != (fb >= 0)
    xa, xb = V[:, :, ea], V[:, :, eb]
    t = np.full(crossing.shape, 0.5)
    rows = np.nonzero(crossing.any(axis=(1, 2)))[0]
    if len(rows):
        tr = segment_roots(el, phi_cell[rows], xa[rows].reshape(len(rows), -1, 3),
                           xb[rows].reshape(len(rows), -1, 3), fa[rows].reshape(len(rows), -1),
                           fb[rows].reshape(len(rows), -1)).reshape(len(rows), T, 6)
        t[rows] = np.where(crossing[rows], tr, 0.5)
    P = np.concatenate([V, xa + t[..., None] * (xb - xa)], axis=2)   # (k, T, 10, 3)
    row = pattern + 16 * quad_diagonals(el, phi_cell, P, V, pattern)
    # interface edges and their projected mid-nodes
    ie = tt.IFACE_EDGES[row]                                   # (k, T, 5, 2)
    live_e = (ie[..., 0] >= 0) & tlive[..., None]
    pa, pb = _take(P, ie[..., 0]), _take(P, ie[..., 1])
    opp = tt.SHARED_FACE[np.maximum(ie[..., 0] - 4, 0), np.maximum(ie[..., 1] - 4, 0)]   # (k, T, 5)
    fv = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])[np.maximum(opp, 0)]      # face vertices
    q = _take(V, fv)                                           # (k, T, 5, 3, 3)
    fn = np.cross(q[..., 1, :] - q[..., 0, :], q[..., 2, :] - q[..., 0, :])
    fn = np.where((opp >= 0)[..., None], fn, 0.0)
    M = 0.5 * (pa + pb)
    off = np.zeros(k, np.int64)
    lrows = np.nonzero(live_e.any(axis=(1, 2)))[0]
    if len(lrows):
        n = len(lrows)
        tet = np.broadcast_to(V[lrows][:, :, None], (n, T, tt.MAX_IFACE_EDGES, 4, 3))
        Mp, left = project_midpoints(el, phi_cell[lrows], pa[lrows].reshape(n, -1, 3),
                                     pb[lrows].reshape(n, -1, 3), fn[lrows].reshape(n, -1, 3),
                                     tet.reshape(n, -1, 4, 3), None if xc is None else xc[lrows])
        M[lrows] = np.where(live_e[lrows][..., None], Mp.reshape(n, T, -1, 3), M[lrows])
        off[lrows] = (left.reshape(n, T, -1) & live_e[lrows]).sum(axis=(1, 2))
    # sub-tetrahedra: vertices from P, mid-nodes straight or projected
    st = tt.SUBTETS[row]                                   # (k, T, 6, 4)
    sv = _take(P, st)                                          # (k, T, 6, 4, 3)
    e10 = tt.TETRA10_EDGES
    smid = 0.5 * (sv[..., e10[:, 0], :] + sv[..., e10[:, 1], :])
    mi = tt.SUBTET_MID[row]                                # (k, T, 6, 6)
    smid = np.where((mi >= 0)[..., None], _take(M, mi), smid)
    snodes = np.concatenate([sv, smid], axis=3)                # (k, T, 6, 10, 3)
    sside = np.where(tlive[..., None], tt.SUBTET_SIDE[row], 0)
    # facets
    fc = tt.FACETS[row]                                    # (k, T, 2, 3)
    fvx = _take(P, fc)
    fm = _take(M, tt.FACET_MID[row])                       # (k, T, 2, 3, 3)
    fnodes = np.concatenate([fvx, fm], axis=3)                 # (k, T, 2, 6, 3)
    flive = (fc[..., 0] >= 0) & tlive[..., None]
    bad = negative_sides(snodes, sside)
    subs = _compact(SubTets(cells, snodes.reshape(k, -1, 10, 3), sside.reshape(k, -1)))
    facets = _compact_facets(Facets(cells, fnodes.reshape(k, -1, 6, 3), flive.reshape(k, -1)))
    return subs, facets, bad, off


#: rounds of :func:`split_double_crossings` (each splits every tetrahedron at most once)
SPLIT_ROUNDS = 3
#: interior points per edge where :func:`split_double_crossings` looks for the other sign
#: (besides the extremum of the quadratic through the ends and the middle: exact on the
#: parent's edges, where LN is quadratic)
DIP_SAMPLES = 7


def split_double_crossings(el: Element, phi_cell: FloatArray, V: FloatArray, pv: FloatArray
                           ) -> tuple[FloatArray, FloatArray, BoolArray]:
    """Split the tetrahedra ``V (k, T, 4, 3)`` (vertex LN values ``pv (k, T, 4)``) that have
    an edge whose ends have one sign while LN takes the other inside it: the interface
    crosses that edge twice, cutting a thin cap of the other side off the edge, which the
    signs at the vertices do not show.  Such a tetrahedron is split at the point of the
    edge where LN is farthest on the other side, into the two tetrahedra that replace one
    or the other end by that point (both keep the orientation); each has then one crossing
    on each half of the edge, and the marching-tetrahedra tables cut the cap.  Repeated
    :data:`SPLIT_ROUNDS` times (a tetrahedron with two such edges).  The split point lies on
    the edge and LN along the edge is the same in every cell sharing it (the parent's P2 /
    serendipity interpolant restricted to an edge or a face depends on that edge's or
    face's nodes only), so neighbouring cells split their common faces alike.

    A vertex with LN = 0 counts as + (the tables' rule); the other sign must be reached by
    more than round-off (1e-12 of the cell's largest |LN|).  Returns the vertices ``(k, T',
    4, 3)``, their LN values and which tetrahedra are live ``(k, T')`` (rows are padded with
    copies of their first tetrahedron, not live).
    """
    k = len(V)
    live = np.ones(V.shape[:2], bool)
    if k == 0:
        return np.array(V), np.array(pv), live
    V, pv = np.array(V), np.array(pv)
    tol = 1e-12 * np.abs(phi_cell).max(axis=1)                                 # (k,)
    for _ in range(SPLIT_ROUNDS):
        edge, t, value = _deepest_dips(el, phi_cell, V, pv, tol)               # (k, T) each
        edge = np.where(live, edge, -1)
        split = edge >= 0
        if not split.any():
            break
        extra = split.sum(axis=1)
        width = V.shape[1] + int(extra.max())
        V2 = np.broadcast_to(V[:, :1], (k, width, 4, 3)).copy()
        pv2 = np.broadcast_to(pv[:, :1], (k, width, 4)).copy()
        live2 = np.zeros((k, width), bool)
        T = V.shape[1]
        V2[:, :T], pv2[:, :T], live2[:, :T] = V, pv, live
        r, c = np.nonzero(split)
        slot = T + (np.cumsum(split, axis=1) - 1)[r, c]                           # the second child's row
        a, b = tt.TET_EDGES[edge[r, c], 0], tt.TET_EDGES[edge[r, c], 1]
        P = V[r, c, a] + t[r, c, None] * (V[r, c, b] - V[r, c, a])
        V2[r, slot], pv2[r, slot], live2[r, slot] = V[r, c], pv[r, c], True
        V2[r, c, a], pv2[r, c, a] = P, value[r, c]                              # (P, b, ...): a replaced
        V2[r, slot, b], pv2[r, slot, b] = P, value[r, c]                        # (a, P, ...): b replaced
        V, pv, live = V2, pv2, live2
    return V, pv, live


def face_diagonal_dips(el: Element, phi_cell: FloatArray, chunk: int = 2048) -> BoolArray:
    """Cells ``(k,)`` (node values ``phi_cell (k, nn)``) one of whose face diagonals that
    are edges of the reference tetrahedra (HEXA20: the Kuhn split's; TETRA10 has none) has
    ends of one sign while LN has the other inside it, by the test of
    :func:`split_double_crossings` (the extremum of the quadratic through the ends and the
    middle, :data:`DIP_SAMPLES` points; 1e-12 of the cell's largest |LN|).

    A cap crossing a face without crossing its edges (a sphere whose top is a few
    hundredths of h above a plane of vertices, on a coarse mesh): the cell below it, cut,
    splits the face's diagonal at the cap, and its interface reaches the face there; the
    cell above, all of whose nodes may have one sign, must be cut too, or the interface
    has a hole where the cap crosses the face."""
    k = len(phi_cell)
    out = np.zeros(k, bool)
    tets = parent_tets(el)
    X = el.ref_nodes[: el.nv]
    pairs = {tuple(sorted((int(t[a]), int(t[b])))) for t in tets for a, b in tt.TET_EDGES}
    edges = {tuple(sorted(map(int, e[:2]))) for e in el.edges}
    diag = np.array([p for p in sorted(pairs - edges)
                     if np.any(np.all(X[list(p)] == X[p[0]], axis=0) & (np.abs(X[p[0]]) == 1))],
                    dtype=np.int64).reshape(-1, 2)
    if not len(diag) or not k:
        return out
    ts = np.arange(1, DIP_SAMPLES + 1) / (DIP_SAMPLES + 1)
    xa, xb = X[diag[:, 0]], X[diag[:, 1]]                                       # (e, 3)
    for lo in range(0, k, chunk):
        pc = phi_cell[lo:lo + chunk]
        n = len(pc)
        fa, fb = pc[:, diag[:, 0]], pc[:, diag[:, 1]]                           # (n, e)
        tol = 1e-12 * np.abs(pc).max(axis=1)
        same = (fa >= 0) == (fb >= 0)
        sgn = np.where(fa >= 0, 1.0, -1.0)
        fm = phi_at(el, pc, np.broadcast_to(0.5 * (xa + xb), (n,) + xa.shape))
        A, B = 2 * fa + 2 * fb - 4 * fm, -3 * fa + 4 * fm - fb
        with np.errstate(divide="ignore", invalid="ignore"):
            ext = np.where(np.abs(A) > 0, -B / np.where(np.abs(A) > 0, 2 * A, 1.0), 0.5)
        ext = np.clip(np.nan_to_num(ext, nan=0.5), 1e-3, 1 - 1e-3)
        t = np.concatenate([ext[..., None], np.broadcast_to(ts, ext.shape + ts.shape)], axis=-1)
        x = xa[:, None] + t[..., None] * (xb - xa)[:, None]                      # (n, e, s, 3)
        depth = -sgn[..., None] * phi_at(el, pc, x)
        dmax = depth.max(axis=-1)
        dip = same & (dmax > tol[:, None]) & ((sgn > 0) | (dmax > 0))
        out[lo:lo + chunk] = dip.any(axis=1)
    return out


def _deepest_dips(el: Element, phi_cell: FloatArray, V: FloatArray, pv: FloatArray, tol: FloatArray
                  ) -> tuple[IntArray, FloatArray, FloatArray]:
    """Per tetrahedron, its first edge (:data:`tet_tables.TET_EDGES` order) whose ends have
    one sign while LN has the other inside (-1: none), the parameter of the point where LN
    is farthest on the other side among the candidates (the extremum of the quadratic
    through the ends and the middle, and :data:`DIP_SAMPLES` evenly spaced points), and LN
    there."""
    k, T = V.shape[:2]
    ea, eb = tt.TET_EDGES.T
    fa, fb = pv[..., ea], pv[..., eb]                                          # (k, T, 6)
    same = (fa >= 0) == (fb >= 0)
    sgn = np.where(fa >= 0, 1.0, -1.0)
    xa, xb = V[:, :, ea], V[:, :, eb]
    fm = phi_at(el, phi_cell, 0.5 * (xa + xb))
    A, B = 2 * fa + 2 * fb - 4 * fm, -3 * fa + 4 * fm - fb                    # f(t) = A t^2 + B t + fa
    with np.errstate(divide="ignore", invalid="ignore"):
        ext = np.where(np.abs(A) > 0, -B / np.where(np.abs(A) > 0, 2 * A, 1.0), 0.5)
    ext = np.clip(np.nan_to_num(ext, nan=0.5), 1e-3, 1 - 1e-3)
    ts = np.concatenate([ext[..., None], np.broadcast_to(np.arange(1, DIP_SAMPLES + 1) / (DIP_SAMPLES + 1),
                                                         ext.shape + (DIP_SAMPLES,))], axis=-1)   # (k, T, 6, s)
    x = xa[..., None, :] + ts[..., None] * (xb - xa)[..., None, :]
    f = phi_at(el, phi_cell, x.reshape(k, -1, 3)).reshape(ts.shape)
    depth = -sgn[..., None] * f                                                # > 0: the other sign
    best = np.argmax(depth, axis=-1)
    dmax = np.take_along_axis(depth, best[..., None], axis=-1)[..., 0]
    dip = same & (dmax > tol[:, None, None]) & ((sgn > 0) | (dmax > 0))        # (k, T, 6)
    edge = np.where(dip.any(axis=-1), np.argmax(dip, axis=-1), -1)
    e = np.maximum(edge, 0)[..., None]
    t = np.take_along_axis(np.take_along_axis(ts, best[..., None], axis=-1)[..., 0], e, axis=-1)[..., 0]
    value = np.take_along_axis(np.take_along_axis(f, best[..., None], axis=-1)[..., 0], e, axis=-1)[..., 0]
    return edge, t, value


def _front(live: BoolArray) -> tuple[IntArray, int]:
    """Per row, the order putting live entries first, and the largest live count."""
    order = np.argsort(~live, axis=1, kind="stable")
    return order, int(live.sum(axis=1).max()) if live.size else 0


def _compact(sub: SubTets) -> SubTets:
    order, n = _front(sub.side != 0)
    order = order[:, :max(n, 1)]
    return SubTets(sub.cells, np.take_along_axis(sub.nodes, order[..., None, None], axis=1),
                   np.take_along_axis(sub.side, order, axis=1))


def _compact_facets(fac: Facets) -> Facets:
    order, n = _front(fac.live)
    order = order[:, :max(n, 1)]
    return Facets(fac.cells, np.take_along_axis(fac.nodes, order[..., None, None], axis=1),
                  np.take_along_axis(fac.live, order, axis=1))


def subtet_jacobians(nodes: FloatArray, zeta: FloatArray) -> FloatArray:
    """det of the maps reference tetrahedron -> parent ``xi`` at ``zeta (q, 3)``:
    ``nodes (..., 10, 3)`` -> ``(..., q)``."""
    J = np.einsum("...ai,qaj->...qij", nodes, TETRA10.dshape(zeta))
    return determinants(J)


def folded(sub: SubTets) -> BoolArray:
    """Cells ``(k,)`` with a sub-tetrahedron whose Jacobian is negative somewhere (measured
    at the points of a degree-4 rule): a diagnostic, the integrals stay right (see
    :func:`negative_sides`)."""
    zeta, _ = TETRA10.quadrature(4)
    det = subtet_jacobians(sub.nodes, zeta)                    # (k, ns, q)
    return ((det < 0).any(axis=-1) & (sub.side != 0)).any(axis=1)


def negative_sides(nodes: FloatArray, side: IntArray) -> BoolArray:
    """Cells ``(k,)`` where a side of one reference tetrahedron has a negative volume.

    ``nodes (k, T, 6, 10, 3)``, ``side (k, T, 6)``: the sub-tetrahedra of each of the
    ``T`` tetrahedra of each cell.  Sub-tetrahedra share their faces node for node
    (a mid-node depends on its edge only), so the sub-tetrahedra of a side form a
    chain whose boundary is the side's boundary, and integrals with the signed
    Jacobian are integrals over the side even where a thin sub-tetrahedron folds
    under a curved facet.  A side of negative volume means the facets pass outside
    their tetrahedron: the mesh is too coarse for the interface there.
    """
    zeta, w = TETRA10.quadrature(4)
    vol = subtet_jacobians(nodes, zeta) @ w                    # (k, T, 6)
    whole = np.abs(vol).sum(axis=2, keepdims=True)
    bad = [((vol * (side == s)).sum(axis=2) < -1e-10 * whole[..., 0]) for s in (-1, 1)]
    return (bad[0] | bad[1]).any(axis=1)
