"""Rigid-body motions the imposed displacements leave free, in any dimension.

A rigid motion of a body is ``u(p) = a + w x (p - c)`` (in 2-D, ``w`` along z): 3
unknowns in 2-D, 6 in 3-D.  Each imposed component ``c`` at a node ``p`` of the
body is one linear condition on them, a row of the matrix of the rigid modes at
the imposed components; the motion is held when that matrix has full rank.  The
null space, when there is one, says which motions are free: translations along
the axes with no imposed component, and rotations.

Bodies are the connected parts of the mesh (cells sharing a side: an edge in 2-D,
a face in 3-D).  Used by :mod:`xfemcontact.preflight` for 3-D meshes (2-D meshes
keep their own check, which also knows the two sides of a ``free`` interface).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.case.load import Case
    from xfemcontact.mesh.raw import RawMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]

AXES = "xyz"
#: singular values below this fraction of the largest count as zero
RANK_TOL = 1e-9


def rigid_modes(p: FloatArray, component: IntArray, centre: FloatArray, size: float) -> FloatArray:
    """Rows ``(k, m)`` of the rigid modes at imposed components: for the point ``p (k, d)``
    and component ``component (k,)``, the value of each mode (``d`` translations, then
    the rotations, about ``centre``, scaled by ``size`` (m) to be of order one)."""
    k, d = p.shape
    r = (p - centre) / size
    rows = [np.eye(d)[component]]
    if d == 2:
        rot = np.stack([-r[:, 1], r[:, 0]], axis=1)                  # e_z x r
        rows.append(rot[np.arange(k), component][:, None])
    else:
        for axis in range(3):
            rot = np.cross(np.eye(3)[axis], r)                       # e_axis x r
            rows.append(rot[np.arange(k), component][:, None])
    return np.concatenate(rows, axis=1)


def free_motions(rows: FloatArray, d: int) -> str | None:
    """The rigid motions ``rows`` (see :func:`rigid_modes`) leave free, in words, or None."""
    m = d + (1 if d == 2 else 3)
    if len(rows) == 0:
        null = np.eye(m)
    else:                             # padded to m rows: V holds the whole null space
        padded = np.vstack([rows, np.zeros((max(0, m - len(rows)), m))])
        _, sv, vt = np.linalg.svd(padded, full_matrices=False)
        rank = int((sv > RANK_TOL * sv.max()).sum()) if sv.max() > 0 else 0
        null = vt[rank:].T                                           # (m, free)
    if null.shape[1] == 0:
        return None
    comps = "DX DY DZ".split()[:d]
    held = np.abs(rows[:, :d]).max(axis=0) > 0 if len(rows) else np.zeros(d, bool)
    missing = [comps[c] for c in range(d) if not held[c]]
    rotations = null.shape[1] - len(missing)
    parts = []
    if missing:
        axes = " and ".join(AXES[comps.index(c)] for c in missing)
        parts.append(f"nothing imposes {' or '.join(missing)} (translation in {axes} is free)")
    if rotations > 0:
        what = "the rotation is" if rotations == 1 else f"{rotations} rotations are"
        parts.append(f"{what} free (impose displacements at more points"
                     + (", not all on one line)" if d == 3 else ")"))
    return "; ".join(parts)


def bodies(raw: RawMesh) -> IntArray:
    """Body of every cell ``(nc,)``: cells sharing a side are one body."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from xfemcontact.mesh.partition import dual_graph

    el_sides = _sides(raw)
    xadj, adjncy = dual_graph(raw.cells[:, :raw.n_vertices_per_cell], el_sides)
    n = len(raw.cells)
    src = np.repeat(np.arange(n), np.diff(xadj))
    graph = coo_matrix((np.ones(len(src)), (src, adjncy)), shape=(n, n)).tocsr()
    return connected_components(graph, directed=False)[1]


def _sides(raw: RawMesh) -> IntArray | None:
    from xfemcontact.fem.elements import element

    el = element(raw.cell_type)
    return el.faces[:, :el.faces.shape[1] // 2] if el.dim == 3 else None


def check(case: Case, raw: RawMesh) -> str | None:
    """A one-line error when the imposed displacements of ``case`` leave a rigid-body
    motion of a body of ``raw`` free, else None."""
    x, cells = raw.points, raw.cells
    d = x.shape[1]
    body = bodies(raw)
    node_body = np.full(len(x), -1, np.int64)
    node_body[cells.ravel()] = np.repeat(body, cells.shape[1])
    size = float(np.ptp(x[cells.ravel()], axis=0).max()) or 1.0
    pts, comp = [], []
    for bc in case.dirichlet:
        nodes = np.unique(np.concatenate([raw.group_nodes(g) for g in bc.groups]))
        nodes = nodes[node_body[nodes] >= 0]
        for c, name in enumerate(("DX", "DY", "DZ")[:d]):
            if name in bc.components:
                pts.append(nodes)
                comp.append(np.full(len(nodes), c))
    held = np.concatenate(pts) if pts else np.zeros(0, np.int64)
    component = np.concatenate(comp) if comp else np.zeros(0, np.int64)
    n_bodies = int(body.max()) + 1 if len(body) else 0
    for b in range(n_bodies):
        mine = node_body[held] == b
        centre = x[cells[body == b]].reshape(-1, d).mean(axis=0)
        rows = rigid_modes(x[held[mine]], component[mine], centre, size)
        problem = free_motions(rows, d)
        if problem:
            where = "" if n_bodies == 1 else \
                (f" for the part of the mesh made of {int((body == b).sum())} cell(s) around "
                 f"({', '.join(f'{v:.4g}' for v in centre)}) (it shares no side with the rest)")
            return f"{case.source}: dirichlet: rigid-body motion not prevented{where}: {problem}"
    return None
