"""Cutting a tetrahedron by the signs of LN at its vertices: the lookup tables.

A tetrahedron's *points* are numbered 0-3 (its vertices) and 4-9 (the points
where LN vanishes on its edges :data:`TET_EDGES`, in that order).  A vertex is
on the + side when LN >= 0 (a vertex with LN = 0 counts as +: the points on its
edges towards - vertices then coincide with it, and the sub-cells and facets
that collapse have zero measure).  The *pattern* of a tetrahedron is
``sum_i (LN_i >= 0) << i``, 0 to 15.

Every table has 32 rows, ``pattern + 16 * diagonal``: for the two-against-two
patterns, whose interface is the quadrangle :data:`QUADS` ``(16, 4)`` (q0, q1,
q2, q3; -1 rows for the others), ``diagonal`` 0 cuts it along q0 q2 and 1 along
q1 q3 (the caller takes the diagonal closer to the zero set); for the other
patterns both rows are the same.  The tables give

* :data:`SUBTETS` ``(32, 6, 4)`` points of up to 6 sub-tetrahedra (-1 padding),
  in TETRA10's vertex order with a positive Jacobian when the tetrahedron is
  positively oriented (``det[v1 - v0, v2 - v0, v3 - v0] > 0``), and
  :data:`SUBTET_SIDE` ``(32, 6)`` their side (-1, +1, 0 for padding).  Patterns
  0 and 15 are the whole tetrahedron.
* :data:`FACETS` ``(32, 2, 3)`` points of up to 2 interface triangles, with
  the right-hand normal pointing from - to +.
* :data:`IFACE_EDGES` ``(32, 5, 2)`` the interface edges (pairs of edge points:
  the sides of the facets and the diagonal of a quadrangular interface), whose
  mid-nodes are moved onto the zero set of LN; :data:`SUBTET_MID` ``(32, 6, 6)``
  and :data:`FACET_MID` ``(32, 2, 3)`` index them for each edge of a sub-cell
  (in TETRA10's / TRIA6's edge order), -1 for a straight edge.

The cases are the classical ones: one vertex against three (the interface is a
triangle, one side a tetrahedron, the other a truncated tetrahedron, a wedge)
and two against two (the interface is a quadrangle, both sides wedges).  Wedges
are split into three tetrahedra by the smallest-rank rule of Dompierre et al.
(1999, "How to subdivide pyramids, prisms and hexahedra into tetrahedra"): each
quadrangular face is cut by the diagonal through its point of smallest rank (the
point index, but the chosen diagonal's first point ranks first), so the two
wedges of a 2-2 cut agree on the diagonal of their common interface quadrangle.  The tables are built once at import, oriented on a reference
tetrahedron cut through the midpoints of its edges.
"""
from __future__ import annotations

from itertools import combinations
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]

#: the edges of a tetrahedron (vertex pairs); edge point 4 + e lies on edge e
TET_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])
#: TETRA10's edges by vertex position (a sub-tetrahedron's nodes are in TETRA10's order)
TETRA10_EDGES = np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]])
#: TRIA6's edges by vertex position
TRIA6_EDGES = np.array([[0, 1], [1, 2], [2, 0]])

MAX_SUBTETS, MAX_FACETS, MAX_IFACE_EDGES = 6, 2, 5

_REF = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])


def _edge_point(a: int, b: int) -> int:
    """Point index of the edge point between vertices ``a`` and ``b``."""
    key = sorted((a, b))
    return 4 + int(np.nonzero((TET_EDGES == key).all(axis=1))[0][0])


def _split_wedge(bottom: list[int], top: list[int], rank: dict[int, int]) -> list[list[int]]:
    """Three tetrahedra of the wedge ``bottom (3)``, ``top (3)`` (bottom[i] - top[i]
    lateral edges), by the smallest-rank rule (``rank``: point -> its rank)."""
    v = [rank[p] for p in bottom + top]
    i = v.index(min(v))
    if i >= 3:                                   # bring the smallest to the bottom
        bottom, top, i = top, bottom, i - 3
    bottom = bottom[i:] + bottom[:i]
    top = top[i:] + top[:i]
    v0, v1, v2, v3, v4, v5 = bottom + top
    if min(rank[v1], rank[v5]) < min(rank[v2], rank[v4]):
        return [[v0, v1, v2, v5], [v0, v1, v5, v4], [v0, v4, v5, v3]]
    return [[v0, v1, v2, v4], [v0, v4, v2, v5], [v0, v4, v5, v3]]


def _quad_triangles(q: list[int], rank: dict[int, int]) -> list[list[int]]:
    """Two triangles of the quadrangle ``q`` (cyclic), cut by the diagonal through its
    smallest rank (the wedges' rule)."""
    i = [rank[p] for p in q].index(min(rank[p] for p in q))
    q = q[i:] + q[:i]
    return [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]


def _case(pattern: int, diagonal: int) -> tuple[list[tuple[list[int], int]], list[list[int]], list[int]]:
    """Sub-tetrahedra (points, side), interface triangles (unoriented) and interface
    quadrangle (empty if none) of one pattern; ``diagonal`` 0 or 1: the quadrangle
    (q0, q1, q2, q3) is cut along q0 q2 or q1 q3."""
    rank = {p: p for p in range(10)}
    plus = [v for v in range(4) if pattern >> v & 1]
    minus = [v for v in range(4) if not pattern >> v & 1]
    if not plus or not minus:
        return [([0, 1, 2, 3], 1 if plus else -1)], [], []
    if len(plus) == 2:
        (a, b), (c, d) = plus, minus
        ac, ad, bc, bd = (_edge_point(*e) for e in ((a, c), (a, d), (b, c), (b, d)))
        quad = [ac, ad, bd, bc]
        rank[quad[diagonal]] = -1
        tets = [(t, 1) for t in _split_wedge([a, ac, ad], [b, bc, bd], rank)]
        tets += [(t, -1) for t in _split_wedge([c, ac, bc], [d, ad, bd], rank)]
        return tets, _quad_triangles(quad, rank), quad
    (a,), others, s = (plus, minus, 1) if len(plus) == 1 else (minus, plus, -1)
    cut = [_edge_point(a, o) for o in others]
    tets = [([a] + cut, s)] + [(t, -s) for t in _split_wedge(others, cut, rank)]
    return tets, [cut], []


def _orient(points: list[int], pts: FloatArray) -> list[int]:
    x = pts[points]
    if np.linalg.det((x[1:] - x[0]).T) < 0:
        points = [points[0], points[2], points[1], points[3]]
    return points


def _build() -> tuple[IntArray, ...]:
    subtets = np.full((32, MAX_SUBTETS, 4), -1)
    side = np.zeros((32, MAX_SUBTETS), np.int64)
    facets = np.full((32, MAX_FACETS, 3), -1)
    iedges = np.full((32, MAX_IFACE_EDGES, 2), -1)
    sub_mid = np.full((32, MAX_SUBTETS, 6), -1)
    fac_mid = np.full((32, MAX_FACETS, 3), -1)
    quads = np.full((16, 4), -1)
    # the reference tetrahedron cut through its edge midpoints by a linear LN
    pts = np.r_[_REF, 0.5 * (_REF[TET_EDGES[:, 0]] + _REF[TET_EDGES[:, 1]])]
    for row in range(32):
        pattern, diagonal = row % 16, row // 16
        tets, tris, quad = _case(pattern, diagonal)
        if quad:
            quads[pattern] = quad
        plus_centre = _REF[[v for v in range(4) if pattern >> v & 1] or [0]].mean(axis=0)
        oriented = []
        for tri in tris:
            x = pts[tri]
            n = np.cross(x[1] - x[0], x[2] - x[0])
            oriented.append(tri if n @ (plus_centre - x.mean(axis=0)) > 0 else [tri[0], tri[2], tri[1]])
        pairs = sorted({tuple(sorted((t[i], t[j]))) for t in oriented for i, j in TRIA6_EDGES})
        index = {p: n for n, p in enumerate(pairs)}
        if pairs:
            iedges[row, :len(pairs)] = pairs
        for n, tri in enumerate(oriented):
            facets[row, n] = tri
            fac_mid[row, n] = [index[tuple(sorted((tri[i], tri[j])))] for i, j in TRIA6_EDGES]
        for n, (tet, s) in enumerate(tets):
            tet = _orient(tet, pts)
            # TETRA10's reference vertices (0,0,0), (0,1,0), (1,0,0), (0,0,1) are left-handed:
            # list the second and third points swapped so that its map has det > 0
            tet = [tet[0], tet[2], tet[1], tet[3]]
            subtets[row, n] = tet
            side[row, n] = s
            sub_mid[row, n] = [index.get(tuple(sorted((tet[i], tet[j]))), -1) for i, j in TETRA10_EDGES]
    return subtets, side, facets, iedges, sub_mid, fac_mid, quads


SUBTETS, SUBTET_SIDE, FACETS, IFACE_EDGES, SUBTET_MID, FACET_MID, QUADS = _build()

#: pairs of tetrahedron edges sharing a vertex (their points lie on a common face):
#: ``SHARED_FACE[e, f]`` the vertex opposite that face, -1 for opposite edges
SHARED_FACE = np.full((6, 6), -1)
for _e, _f in combinations(range(6), 2):
    _common = set(TET_EDGES[_e]) | set(TET_EDGES[_f])
    if len(_common) == 3:
        SHARED_FACE[_e, _f] = SHARED_FACE[_f, _e] = ({0, 1, 2, 3} - _common).pop()
