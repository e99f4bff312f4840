"""Uniform refinement of a RawMesh, like code_aster's MACR_ADAP_MAIL RAFFINEMENT_UNIFORME.

Each QUAD8 is split into 4 QUAD8 and each TRIA6 into 4 TRIA6 (three corner
triangles and the middle one).  Old nodes keep their indices, so node groups
stay valid; old mid-edge nodes become vertices, and the centre of a QUAD8
(image of the reference point (0, 0)) becomes a vertex.  Every new mid-edge
node is the image, through the parent's isoparametric map, of the midpoint of
the child's edge in the parent's reference cell: curved edges stay on their
curve, straight meshes get plain midpoints.

New nodes are numbered after the old ones: first two per parent edge (the
halves of the edge, edges keyed by their sorted vertex pair, so shared edges
get shared nodes), then those inside each parent cell (QUAD8: the centre and
the 4 mid-nodes of the edges around it; TRIA6: the 3 mid-nodes of the middle
triangle).  Children of parent cell ``c`` are cells ``4c .. 4c+3``.
"""
from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING, Sequence

import numpy as np

from xfemcontact.errors import MeshError
from xfemcontact.fem.elements import Seg3, element
from xfemcontact.mesh.raw import RawMesh

if TYPE_CHECKING:
    from typing import TypedDict

    from numpy.typing import NDArray

    from xfemcontact.fem.elements import Element

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]

    class ChildTable(TypedDict):
        """What :func:`_child_table` returns (see there)."""

        children: IntArray      # (4, nn) indices into a parent's extended node list
        child_xi: FloatArray    # (4, nn, 2) parent reference coordinates of the children's nodes
        inner: FloatArray       # (ni, 2) parent reference coordinates of the inner new nodes
        n_inner: int

# Children of each parent, as the parent's reference points of their vertices,
# counter-clockwise (a vertex is a parent node or, for QUAD8, the centre).
_CHILD_VERTICES = {
    "TRIA6": [[(0, 0), (.5, 0), (0, .5)], [(.5, 0), (1, 0), (.5, .5)],
              [(0, .5), (.5, .5), (0, 1)], [(.5, 0), (.5, .5), (0, .5)]],
    "QUAD8": [[(-1, -1), (0, -1), (0, 0), (-1, 0)], [(0, -1), (1, -1), (1, 0), (0, 0)],
              [(0, 0), (1, 0), (1, 1), (0, 1)], [(-1, 0), (0, 0), (0, 1), (-1, 1)]],
}


def refine_uniform(mesh: RawMesh, levels: int = 1) -> RawMesh:
    """``mesh`` refined ``levels`` times (each time ``4 x`` the cells); ``mesh`` is unchanged.

    Cell groups: children inherit their parent's groups.  Edge groups: each
    SEG3 ``(a, b, m)`` becomes ``(a, m, n_a)`` and ``(m, b, n_b)`` with the
    same new nodes as the cells (an edge that is no cell edge gets its own,
    from its SEG3 map).  Node groups are unchanged.  Orientation is inherited
    (counter-clockwise parents give counter-clockwise children).
    """
    if not isinstance(levels, (int, np.integer)) or isinstance(levels, bool) or levels < 0:
        raise MeshError(f"refine_uniform: levels must be a non-negative integer (got {levels!r})")
    if levels and mesh.dim == 3:
        raise MeshError(f"{mesh.source}: uniform refinement is for 2-D meshes only (for now)")
    if levels:                        # the refined mesh must fit before it is built
        from xfemcontact import resources

        resources.check_cells(mesh.cell_type, len(mesh.cells) * 4 ** int(levels), resources.current_nprocs(),
                              f"{mesh.source}: refined {levels} time(s)", error=MeshError)
    for _ in range(int(levels)):
        mesh = _refine_once(mesh)
    return mesh


def _refine_once(mesh: RawMesh) -> RawMesh:
    """One level of refinement: a new RawMesh with 4x the cells of ``mesh``."""
    ref = element(mesh.cell_type)
    table = _child_table(mesh.cell_type)
    n_old, ne = len(mesh.points), len(mesh.cells)
    cell_edges = mesh.cells[:, ref.edges].reshape(-1, 3)               # (ne*nedge, 3)
    group_edges = list(mesh.edge_groups.values())
    halves, edge_points = _split_edges(mesh.points, [cell_edges] + group_edges, n_old)
    inner_points = _inner_points(mesh, table["inner"])                 # (ne, ni, 2)
    first_inner = n_old + len(edge_points)
    inner = first_inner + np.arange(ne * table["n_inner"]).reshape(ne, -1)
    ext = np.concatenate([mesh.cells, halves[0].reshape(ne, -1), inner], axis=1)
    cells = ext[:, table["children"]].reshape(-1, ref.nn)               # (4 ne, nn)
    edge_groups = {name: _split_group(edges, h)
                   for (name, edges), h in zip(mesh.edge_groups.items(), halves[1:])}
    children = np.arange(4)
    points = np.concatenate([mesh.points, edge_points, inner_points.reshape(-1, 2)])
    return RawMesh(
        points=points,
        cell_type=mesh.cell_type,
        cells=cells,
        cell_groups={name: (4 * np.asarray(c, dtype=np.int64)[:, None] + children).ravel()
                     for name, c in mesh.cell_groups.items()},
        edge_groups=edge_groups,
        node_groups={name: np.array(n, copy=True) for name, n in mesh.node_groups.items()},
        point_data=_refine_point_data(mesh, ref, table, cells, len(points)),
        source=mesh.source if "(refined)" in mesh.source else f"{mesh.source} (refined)")


def _split_edges(points: FloatArray, edge_lists: Sequence[IntArray],
                 first: int) -> tuple[list[IntArray], FloatArray]:
    """New nodes at the quarter points of every distinct edge.

    ``edge_lists``: arrays ``(k, 3)`` of SEG3 rows ``(a, b, mid)``; an edge is
    identified by its sorted vertex pair.  Each distinct edge ``u`` gets nodes
    ``first + 2u`` (the half next to its smaller vertex) and ``first + 2u + 1``,
    at SEG3 parameters -1/2 and +1/2 from the smaller vertex.

    Returns ``(halves, coords)``: ``halves[i]`` is ``(k_i, 2)``, the new nodes
    next to ``a`` and next to ``b`` of each row of ``edge_lists[i]``; ``coords``
    is ``(2 n_distinct, 2)`` (m).
    """
    rows = np.concatenate(edge_lists).astype(np.int64)
    lo, hi = np.minimum(rows[:, 0], rows[:, 1]), np.maximum(rows[:, 0], rows[:, 1])
    _, first_row, u = np.unique(lo * len(points) + hi, return_index=True,
                                return_inverse=True)
    u = u.ravel()
    rep = rows[first_row]
    swap = rep[:, 0] > rep[:, 1]
    rep[swap, :2] = rep[swap, 1::-1]                                    # (lo, hi, mid)
    seg = Seg3.shape(np.array([-0.5, 0.5]))                             # (2, 3)
    coords = np.einsum("sn,enx->esx", seg, points[rep]).reshape(-1, 2)
    a_is_hi = (rows[:, 0] > rows[:, 1]).astype(np.int64)
    near = first + 2 * u[:, None] + np.c_[a_is_hi, 1 - a_is_hi]        # (rows, 2)
    return np.split(near, np.cumsum([len(e) for e in edge_lists])[:-1]), coords


def _refine_point_data(mesh: RawMesh, ref: Element, table: ChildTable, cells: IntArray,
                       n_points: int) -> dict[str, FloatArray]:
    """Nodal fields at the new nodes: each parent's interpolation at its children's nodes."""
    if not mesh.point_data:
        return {}
    shape = ref.shape(table["child_xi"].reshape(-1, 2))                # (4 nn, nn)
    out: dict[str, FloatArray] = {}
    for name, f in mesh.point_data.items():
        values = np.zeros(n_points)
        values[cells.ravel()] = np.einsum("in,en->ei", shape, f[mesh.cells]).ravel()
        values[: len(f)] = f
        out[name] = values
    return out


def _inner_points(mesh: RawMesh, xi: FloatArray) -> FloatArray:
    """Images ``(ne, ni, 2)`` (m) of the reference points ``xi (ni, 2)`` in every cell."""
    shape = element(mesh.cell_type).shape(xi)                           # (ni, nn)
    return np.einsum("in,enx->eix", shape, mesh.points[mesh.cells])


def _split_group(edges: IntArray, halves: IntArray) -> IntArray:
    """Rows ``(a, m, n_a)`` and ``(m, b, n_b)`` for each SEG3 row ``(a, b, m)``."""
    a, b, m = edges[:, 0], edges[:, 1], edges[:, 2]
    return np.stack([np.c_[a, m, halves[:, 0]], np.c_[m, b, halves[:, 1]]], axis=1).reshape(-1, 3)


@lru_cache(maxsize=None)
def _child_table(cell_type: str) -> ChildTable:
    """Local connectivity of the 4 children in a parent's "extended" node list.

    The extended list of a parent is: its ``nn`` nodes, then for each edge
    ``k`` the new node next to vertex ``k`` and the one next to vertex
    ``k+1``, then its inner new nodes.  Returns a dict with ``children``
    ``(4, nn)`` indices into that list, ``child_xi`` ``(4, nn, 2)`` the
    parent's reference coordinates of the children's nodes, ``inner``
    ``(ni, 2)`` those of the inner nodes and ``n_inner``.
    """
    ref = element(cell_type)
    a, b, m = (ref.ref_nodes[ref.edges[:, j]] for j in range(3))
    known = np.concatenate([ref.ref_nodes,
                            np.stack([(a + m) / 2, (m + b) / 2], axis=1).reshape(-1, 2)])
    verts = np.array(_CHILD_VERTICES[cell_type], float)                 # (4, nv, 2)
    mids = (verts + np.roll(verts, -1, axis=1)) / 2
    child_xi = np.concatenate([verts, mids], axis=1).reshape(-1, 2)    # (4 nn, 2)
    found: list[FloatArray] = []
    for p in child_xi:                                                   # 4 nn points, once
        if not np.any(np.all(np.isclose(known, p), axis=1)) and \
                not any(np.allclose(q, p) for q in found):
            found.append(p)
    inner = np.array(found)
    everything = np.concatenate([known, inner])
    index = [int(np.flatnonzero(np.all(np.isclose(everything, p), axis=1))[0])
             for p in child_xi]
    return {"children": np.array(index).reshape(4, -1), "child_xi": child_xi.reshape(4, -1, 2),
            "inner": inner, "n_inner": len(inner)}
