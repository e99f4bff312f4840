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
    null = null_space(rows.reshape(-1, d + (1 if d == 2 else 3)))[0]
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
    d = raw.points.shape[1]
    label, exists = (np.repeat(bodies(raw), 2), np.tile([False, True], len(raw.cells))) if phi is None \
        else pieces(raw, phi)
    held_nodes, component, held_body = dirichlet_rows(case, raw, phi, label, exists)
    size = _size(raw)
    for b in np.unique(label[exists]):
        in_body, bcells, centre, rows = _body(raw, b, label, exists, held_nodes, component, held_body, size)
        problem = free_motions(rows, d)
        if problem:
            return f"{case.source}: dirichlet: rigid-body motion not prevented" + \
                _where(len(np.unique(label[exists])), len(bcells), centre, phi is not None,
                       int(np.flatnonzero(in_body)[0]) % 2) + f": {problem}"
    return None


def _body(raw: RawMesh, b: int, label: IntArray, exists: BoolArray, held_nodes: IntArray,
          component: IntArray, held_body: IntArray,
          size: float) -> tuple[BoolArray, IntArray, FloatArray, FloatArray]:
    """Body ``b`` of the pieces ``label``, ``exists``: which pieces it holds ``(2 nc,)``, its
    cells, its centre (m) and the rows of its imposed components (:func:`dirichlet_rows`,
    :func:`rigid_modes` about that centre)."""
    x, d = raw.points, raw.points.shape[1]
    in_body = (label == b) & exists
    bcells = np.flatnonzero(in_body) // 2
    centre = x[raw.cells[bcells]].reshape(-1, d).mean(axis=0)
    mine = held_body == b
    return in_body, bcells, centre, rigid_modes(x[held_nodes[mine]], component[mine], centre, size)


def _size(raw: RawMesh) -> float:
    """The mesh's largest extent (m), the length scale of the rotations."""
    return float(np.ptp(raw.points[raw.cells.ravel()], axis=0).max()) or 1.0


def dirichlet_rows(case: Case, raw: RawMesh, phi: FloatArray | None, label: IntArray,
                   exists: BoolArray) -> tuple[IntArray, IntArray, IntArray]:
    """The imposed components as ``(node, component, body)`` triples, each ``(k,)``: a
    Dirichlet node holds the pieces (``label``, ``exists``: :func:`pieces`, or
    :func:`bodies` repeated on the + side) of its own side in every cell around it, and
    both sides where its group reaches the interface (``phi`` given) or is a node group."""
    x, cells = raw.points, raw.cells
    d = x.shape[1]
    nc, nn = cells.shape
    cell_of = np.repeat(np.arange(nc), nn)
    node_of = cells.ravel()
    own = (phi[node_of] >= 0).astype(np.int64) if phi is not None else np.ones(len(node_of), np.int64)
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
    empty = np.zeros(0, np.int64)
    return (np.concatenate(pts) if pts else empty, np.concatenate(comp) if comp else empty,
            np.concatenate(body_of) if body_of else empty)


def _where(n_bodies: int, n_cells: int, centre: FloatArray, separate: bool, side: int) -> str:
    if n_bodies == 1:
        return ""
    at = f"{n_cells} cell(s) around ({', '.join(f'{v:.4g}' for v in centre)})"
    if separate:
        return (f" for the part on the {'LN > 0' if side else 'LN < 0'} side of the interface ({at}; "
                f"with law = \"free\" each side is a separate body)")
    return f" for the part of the mesh made of {at} (it shares no side with the rest)"


# --- bodies held through an interface that transmits normal forces only ------------------

#: a free motion of a body held through a frictionless interface: a singular value of its
#: (Dirichlet and normal) rows below this fraction of the largest.  The normals are those
#: of the P2 interpolant of LN, exact for quadratic level sets (a circle, a sphere, a
#: plane: round-off there); a distance function's interpolant is a circle to about
#: h^3 / R^2, far above this (measured: tests/test_rigid_interface.py)
NORMAL_RANK_TOL = 1e-8
#: ... and held only weakly below this: a warning.  Measured (smallest / largest singular
#: value of an inclusion's rows, R = 2.3 m in a 10 m plate): the circle as a distance
#: function on 10 x 10 / 20 x 20 / 80 x 80 QUAD8 1.8e-3 / 7.4e-4 / 3.8e-5 (the solve on
#: 10 x 10 interpenetrates by 1e-3 m for displacements of 1e-3 m), ellipses with axes
#: 1.01 R, R 2.3e-3, 1.1 R, R 2.2e-2, every mesh
NEARLY_FREE = 1e-2


#: lattice lines per reference direction along which :func:`interface_samples` looks for
#: the interface (the cell's edges among them); each line is cut into LATTICE segments
LATTICE = 4


def interface_samples(raw: RawMesh, phi: FloatArray) -> tuple[IntArray, FloatArray, FloatArray]:
    """Points of the interface LN = 0 in the cut cells and its unit normals there:
    ``(cell (k,), points (k, d) (m), normals (k, d))``.

    The interface is the zero of the cell's P2 interpolant of LN (the one the solver
    cuts); it is looked for along a lattice of straight lines of the reference cell
    parallel to its axes (:data:`LATTICE` + 1 per direction, the edges among them), a
    root on each segment where LN changes sign (bisection); the normal is grad LN /
    |grad LN| of the interpolant there."""
    from xfemcontact.fem.elements import element

    el = element(raw.cell_type)
    d = el.dim
    pc = phi[raw.cells]
    cut = np.flatnonzero((pc.min(axis=1) < 0) & (pc.max(axis=1) > 0))
    lo, hi = el.ref_nodes.min(axis=0), el.ref_nodes.max(axis=0)
    ticks = np.linspace(0.0, 1.0, LATTICE + 1)
    starts, ends = [], []
    for axis in range(d):                       # segments along ``axis`` through the lattice
        others = np.stack(np.meshgrid(*[ticks] * (d - 1), indexing="ij"), axis=-1).reshape(-1, d - 1)
        base = np.insert(others, axis, 0.0, axis=1)
        for a, b in zip(ticks[:-1], ticks[1:]):
            s0, s1 = base.copy(), base.copy()
            s0[:, axis], s1[:, axis] = a, b
            starts.append(s0)
            ends.append(s1)
    a_ref = lo + np.concatenate(starts) * (hi - lo)                     # (ns, d)
    b_ref = lo + np.concatenate(ends) * (hi - lo)
    inside = el.contains(a_ref, 1e-12) & el.contains(b_ref, 1e-12)
    a_ref, b_ref = a_ref[inside], b_ref[inside]
    fa, fb = pc[cut] @ el.shape(a_ref).T, pc[cut] @ el.shape(b_ref).T   # (c, ns)
    ci, si = np.nonzero(np.sign(fa) * np.sign(fb) < 0)
    t0, t1 = np.zeros(len(ci)), np.ones(len(ci))
    f0 = fa[ci, si]
    va, vb = a_ref[si], b_ref[si]
    vals = pc[cut[ci]]
    for _ in range(60):                         # bisection: LN is no more than quadratic here
        tm = 0.5 * (t0 + t1)
        fm = np.einsum("ka,ka->k", el.shape(va + tm[:, None] * (vb - va)), vals)
        left = np.sign(fm) == np.sign(f0)
        t0, t1 = np.where(left, tm, t0), np.where(left, t1, tm)
        f0 = np.where(left, fm, f0)
    xi = va + (0.5 * (t0 + t1))[:, None] * (vb - va)
    xc = raw.points[raw.cells[cut[ci]]]                                  # (k, nn, d)
    dN = el.dshape(xi)                                                   # (k, nn, d)
    J = np.einsum("kad,kae->kde", xc, dN)                                # dx/dxi
    grad = np.linalg.solve(np.transpose(J, (0, 2, 1)), np.einsum("ka,kae->ke", vals, dN)[..., None])[..., 0]
    norm = np.linalg.norm(grad, axis=1)
    keep = norm > 0
    pts = np.einsum("ka,kad->kd", el.shape(xi), xc)
    return cut[ci][keep], pts[keep], grad[keep] / norm[keep, None]


def held_through_normals(case: Case, raw: RawMesh, phi: FloatArray,
                         law_words: str) -> tuple[str | None, list[str]]:
    """``(error, warnings)``: a one-line error when a side of an interface that transmits
    normal forces only (``law_words``: how the case says so, for the messages) is held by
    nothing else and the normals leave one of its rigid motions free (a circular
    inclusion's rotation, a block's slide along a plane: the problem is singular), and
    warnings where they hold one only weakly (:data:`NEARLY_FREE`).

    Each side is a body (:func:`pieces`); its rows are those of its imposed components
    (:func:`dirichlet_rows`) and, when those leave it free, one per interface sample
    (:func:`interface_samples`) of its cells: the normal component n . u of each rigid
    mode there, as if the other side were held.  Unilateral contact holds only while it
    is pressed: a body the normals hold can still lift off (the solve says so)."""
    d = raw.points.shape[1]
    label, exists = pieces(raw, phi)
    held_nodes, component, held_body = dirichlet_rows(case, raw, phi, label, exists)
    cell, p, n = interface_samples(raw, phi)
    size = _size(raw)
    warnings: list[str] = []
    for b in np.unique(label[exists]):
        in_body, bcells, centre, rows = _body(raw, b, label, exists, held_nodes, component, held_body, size)
        touch = in_body[2 * cell] | in_body[2 * cell + 1]
        if free_motions(rows, d) is None or not touch.any():
            continue                  # held, or not by the interface (the plain check's case)
        normal = sum(n[touch, c, None] * rigid_modes(p[touch], np.full(int(touch.sum()), c), centre, size)
                     for c in range(d))
        null, ratio = null_space(np.vstack([rows, normal]), NORMAL_RANK_TOL)
        side = "LN > 0" if int(np.flatnonzero(in_body)[0]) % 2 else "LN < 0"
        part = (f"{case.source}: interface: the part on the {side} side ({len(bcells)} cell(s) around "
                f"({', '.join(f'{v:.4g}' for v in centre)})) is held only through the interface, and "
                f"{law_words} transmits normal forces only: ")
        if null.shape[1]:
            return (part + f"{describe(null, centre, size)} free (the problem is singular): impose a "
                    f"displacement on that part, or give the interface friction (law = \"contact\", "
                    f"frottement = \"COULOMB\")"), warnings
        if ratio < NEARLY_FREE:
            weak = null_space(np.vstack([rows, normal]), 1.01 * ratio)[0]
            warnings.append(part + f"{describe(weak, centre, size)} nearly free (the normals hold it with "
                            f"{ratio:.2g} of the stiffness they give the other motions): expect "
                            f"inaccurate displacements; a displacement imposed on that part, or friction, "
                            f"holds it")
    return None, warnings


def null_space(rows: FloatArray, tol: float = RANK_TOL) -> tuple[FloatArray, float]:
    """Null space ``(m, free)`` of the rows ``(k, m)`` of rigid modes, singular values
    below ``tol`` times the largest counting as zero, and the smallest singular value
    relative to the largest."""
    m = rows.shape[1]
    padded = np.vstack([rows, np.zeros((max(0, m - len(rows)), m))])
    _, sv, vt = np.linalg.svd(padded, full_matrices=False)
    if sv.max() == 0:
        return np.eye(m), 0.0
    rank = int((sv > tol * sv.max()).sum())
    return vt[rank:].T, float(sv.min() / sv.max())


def describe(null: FloatArray, centre: FloatArray, size: float) -> str:
    """The free rigid motions, the columns of ``null`` (:func:`rigid_modes`' unknowns:
    translations, then rotations about ``centre`` scaled by ``size``), in words: "the
    rotation about (x, y) is", "the translation along (a, b) is", "3 motions are" ..."""
    d = len(centre)
    if null.shape[1] > 1:
        rot = np.linalg.matrix_rank(null[d:], tol=1e-6) if len(null) > d else 0
        kinds = []
        if null.shape[1] - rot:
            kinds.append(f"{null.shape[1] - rot} translation(s)")
        if rot:
            kinds.append(f"{rot} rotation(s)")
        return " and ".join(kinds) + " are"
    v = np.where(np.abs(null[:, 0]) > 1e-9 * np.abs(null[:, 0]).max(), null[:, 0], 0.0)
    v = v * np.sign(v[np.argmax(np.abs(v))])            # largest component positive
    t, w = v[:d], v[d:]
    fmt = lambda a: ", ".join(f"{c:.4g}" for c in a)                    # noqa: E731
    if np.abs(w).max() <= 1e-6 * np.abs(v).max():
        return f"the translation along ({fmt(t / np.linalg.norm(t))}) is"
    if d == 2:
        q = centre + size / w[0] * np.array([-t[1], t[0]])             # u = w/size e_z x (p - q)
        return f"the rotation about ({fmt(q)}) is"
    axis = w / np.linalg.norm(w)
    q = centre + size * np.cross(w, t) / (w @ w)                        # nearest point of the axis
    return f"the rotation about the axis ({fmt(axis)}) through ({fmt(q)}) is"
