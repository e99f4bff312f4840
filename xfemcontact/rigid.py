"""Rigid-body motions the imposed displacements leave free, in any dimension.

A rigid motion of a body is ``u(p) = a + w x (p - c)`` (in 2-D, ``w`` along z): 3
unknowns in 2-D, 6 in 3-D.  Each imposed component ``c`` at a node ``p`` of the
body is one linear condition on them, a row of the matrix of the rigid modes at
the imposed components; the motion is held when that matrix has full rank.  The
null space, when there is one, says which motions are free: translations along
the axes with no imposed component, and rotations.

Bodies are the connected parts of the mesh (cells sharing a side: an edge in 2-D,
a face in 3-D); with a ``free`` interface each side of it is a separate body
(:func:`pieces`).  Used by :mod:`xfemcontact.preflight` for 3-D meshes (2-D meshes
keep their own check).
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
    BoolArray = NDArray[np.bool_]

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


def pieces(raw: RawMesh, phi: FloatArray) -> tuple[IntArray, BoolArray]:
    """Bodies of the pieces ``(cell, side)`` of a mesh cut by a ``free`` interface.

    Piece ``2 c + s`` is the part of cell ``c`` on side ``s`` (0: LN < 0, 1: LN > 0;
    a cell with LN = 0 at every node counts as +).  Two cells sharing a side (a face
    in 3-D, an edge in 2-D) link their pieces of side ``s`` when both have one and
    the shared side has a node strictly on side ``s``.  Returns the body of every
    piece ``(2 nc,)`` and which pieces exist ``(2 nc,)``.
    """
    cells = raw.cells
    nc = len(cells)
    pc = phi[cells]
    has = np.stack([(pc < 0).any(axis=1), (pc > 0).any(axis=1)], axis=1)      # [-, +]
    has[~has.any(axis=1), 1] = True
    c1, c2, snodes = shared_sides(raw)
    a, b = [], []
    for s in (0, 1):
        e = phi[snodes]
        ok = has[c1, s] & has[c2, s] & ((e < 0) if s == 0 else (e > 0)).any(axis=1)
        a.append(2 * c1[ok] + s)
        b.append(2 * c2[ok] + s)
    return _connected(2 * nc, np.concatenate(a), np.concatenate(b)), has.ravel()


def shared_sides(raw: RawMesh) -> tuple[IntArray, IntArray, IntArray]:
    """Pairs of cells sharing a side (face in 3-D, edge in 2-D): ``(c1 (k,), c2 (k,),
    nodes (k, m))``, the nodes of the shared side as ``c1`` numbers them."""
    from xfemcontact.fem.elements import element

    el = element(raw.cell_type)
    sides = el.faces if el.dim == 3 else el.edges
    nvs = sides.shape[1] // 2 if el.dim == 3 else 2
    nodes = raw.cells[:, sides]                                   # (nc, ns, m)
    ns = sides.shape[0]
    keys = np.sort(nodes[..., :nvs], axis=-1).reshape(-1, nvs)
    order = np.lexsort(keys.T[::-1])
    k = keys[order]
    same = np.flatnonzero((k[1:] == k[:-1]).all(axis=1))
    first, second = order[same], order[same + 1]
    return first // ns, second // ns, nodes.reshape(-1, nodes.shape[-1])[first]


def _connected(n: int, a: IntArray, b: IntArray) -> IntArray:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n)).tocsr()
    return connected_components(graph, directed=False)[1]


def _both_sides(raw: RawMesh, groups: tuple[str, ...], phi: FloatArray) -> IntArray:
    """Nodes of ``groups`` that hold both sides (their Heaviside dofs are imposed too,
    :mod:`xfemcontact.dofs.constraints`): nodes of node groups, of edges and faces the
    interface reaches."""
    out = [np.zeros(0, np.int64)]
    for g in groups:
        if g in raw.node_groups:
            out.append(np.asarray(raw.node_groups[g], np.int64).ravel())
        for table in (raw.edge_groups, raw.face_groups):
            if g in table:
                f = np.asarray(table[g], np.int64)
                p = phi[f]
                touch = ~(np.all(p > 0, axis=1) | np.all(p < 0, axis=1))
                out.append(f[touch].ravel())
    return np.concatenate(out)


def check(case: Case, raw: RawMesh, phi: FloatArray | None = None) -> str | None:
    """A one-line error when the imposed displacements of ``case`` leave a rigid-body
    motion of a body of ``raw`` free, else None.

    ``phi``: LN at the nodes of ``raw`` when the interface separates the bodies (law
    ``free``): each side is then a body (:func:`pieces`).  A node of a Dirichlet group
    holds its own side (LN >= 0: +) in every cell around it; where the group's edge or
    face reaches the interface, and for node groups, both sides."""
    x, cells = raw.points, raw.cells
    d = x.shape[1]
    nc, nn = cells.shape
    if phi is None:
        label, exists = np.repeat(bodies(raw), 2), np.tile([False, True], nc)
    else:
        label, exists = pieces(raw, phi)
    # every (cell, node) pair: the pieces the node holds
    cell_of = np.repeat(np.arange(nc), nn)
    node_of = cells.ravel()
    own = (phi[node_of] >= 0).astype(np.int64) if phi is not None else np.ones(len(node_of), np.int64)
    size = float(np.ptp(x[cells.ravel()], axis=0).max()) or 1.0
    pts, comp, body_of = [], [], []
    for bc in case.dirichlet:
        held = np.zeros(len(x), bool)
        held[np.concatenate([raw.group_nodes(g) for g in bc.groups])] = True
        both = np.zeros(len(x), bool)
        if phi is not None:
            both[_both_sides(raw, bc.groups, phi)] = True
        m = held[node_of]
        p = np.r_[2 * cell_of[m] + own[m], 2 * cell_of[m & both[node_of]] + 1 - own[m & both[node_of]]]
        nodes = np.r_[node_of[m], node_of[m & both[node_of]]]
        live = exists[p]
        key = np.unique(np.c_[label[p[live]], nodes[live]], axis=0)          # (body, node) once
        for c, name in enumerate(("DX", "DY", "DZ")[:d]):
            if name in bc.components:
                pts.append(key[:, 1])
                body_of.append(key[:, 0])
                comp.append(np.full(len(key), c))
    held_nodes = np.concatenate(pts) if pts else np.zeros(0, np.int64)
    component = np.concatenate(comp) if comp else np.zeros(0, np.int64)
    held_body = np.concatenate(body_of) if body_of else np.zeros(0, np.int64)
    for b in np.unique(label[exists]):
        mine = held_body == b
        in_body = (label == b) & exists
        bcells = np.flatnonzero(in_body) // 2
        centre = x[cells[bcells]].reshape(-1, d).mean(axis=0)
        rows = rigid_modes(x[held_nodes[mine]], component[mine], centre, size)
        problem = free_motions(rows, d)
        if problem:
            return f"{case.source}: dirichlet: rigid-body motion not prevented" + \
                _where(len(np.unique(label[exists])), len(bcells), centre, phi is not None,
                       int(np.flatnonzero(in_body)[0]) % 2) + f": {problem}"
    return None


def _where(n_bodies: int, n_cells: int, centre: FloatArray, separate: bool, side: int) -> str:
    if n_bodies == 1:
        return ""
    at = f"{n_cells} cell(s) around ({', '.join(f'{v:.4g}' for v in centre)})"
    if separate:
        return (f" for the part on the {'LN > 0' if side else 'LN < 0'} side of the interface ({at}; "
                f"with law = \"free\" each side is a separate body)")
    return f" for the part of the mesh made of {at} (it shares no side with the rest)"
