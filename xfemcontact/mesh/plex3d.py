"""DMPlex of a 3-D quadratic mesh (HEXA20, TETRA10): what differs from 2-D.

PETSc interpolates the cells (``createFromCellList``: faces and edges numbered by
PETSc); the mid-edge nodes are then matched to the edge points by their two
vertices, and the face groups to the face points by their vertices, with sorted
keys (no loop over cells).  PETSc's own vertex order of a cell is not MED's:
:data:`PLEX_VERTICES` reorders (PETSc 3.18 reads a hexahedron as a bottom face with
its outward normal, then the top face with its outward normal; a tetrahedron with
the first face's normal pointing out, as MED's).

The functions here serve :mod:`xfemcontact.mesh.plex` (which calls them for 3-D
meshes; the 2-D build stays there) and do not import it: what both use is in
:mod:`xfemcontact.mesh.labels`.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from xfemcontact._petsc import PETSc
from xfemcontact.errors import MeshError
from xfemcontact.fem.elements import element
from xfemcontact.mesh.labels import _BOUNDARY, _INTERNAL_LABELS, ENTITY, NODE, point_sf_leaves, set_stratum

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.fem.elements import Element
    from xfemcontact.mesh.raw import RawMesh

    IntArray = NDArray[np.int64]

#: our (MED) vertex indices of a cell in the order DMPlex's cell lists take them
PLEX_VERTICES = {"HEXA20": np.array([0, 1, 2, 3, 4, 7, 6, 5]), "TETRA10": np.array([0, 1, 2, 3])}


def cones(dm: PETSc.DMPlex, points: IntArray, size: int) -> IntArray:
    """Cones ``(k, size)`` of DMPlex points that all have ``size`` of them (one call each)."""
    if len(points) == 0:
        return np.zeros((0, size), np.int64)
    out = np.array(list(map(dm.getCone, points.tolist())), dtype=np.int64)
    if out.ndim != 2 or out.shape[1] != size:
        raise MeshError(f"unexpected DMPlex cone sizes (expected {size} a point)")
    return out


def row_keys(rows: IntArray) -> IntArray:
    """Row ids ``(k,)`` equal for rows holding the same set of integers (sorted rows,
    numbered in lexicographic order)."""
    if len(rows) == 0:
        return np.zeros(0, np.int64)
    r = np.sort(rows, axis=1)
    order = np.lexsort(r.T[::-1])                 # (np.unique on rows sorts 10 x slower)
    ranked = r[order]
    fresh = np.r_[True, (ranked[1:] != ranked[:-1]).any(axis=1)]
    out = np.empty(len(r), np.int64)
    out[order] = np.cumsum(fresh) - 1
    return out


def match_rows(rows: IntArray, table: IntArray) -> IntArray:
    """Index in ``table`` of the row holding the same set as each of ``rows`` (-1 if none)."""
    if len(rows) == 0 or len(table) == 0:
        return np.full(len(rows), -1, np.int64)
    ids = row_keys(np.r_[table, rows])
    t, r = ids[:len(table)], ids[len(table):]
    order = np.argsort(t, kind="stable")
    pos = np.minimum(np.searchsorted(t[order], r), len(order) - 1)
    found = order[pos]
    return np.where(t[found] == r, found, -1)


def _face_vertices(dm: PETSc.DMPlex, faces: IntArray, edges_per_face: int,
                   edge_ends: IntArray | None = None) -> IntArray:
    """Vertex points ``(k, edges_per_face)`` of faces (the distinct ends of their edges);
    ``edge_ends (ne, 2)``: the vertex points of every edge point, if known."""
    e = cones(dm, faces, edges_per_face)
    if edge_ends is None:
        ends = cones(dm, e.ravel(), 2).reshape(len(faces), -1)
    else:
        ends = edge_ends[e - dm.getDepthStratum(1)[0]].reshape(len(faces), -1)
    ends = np.sort(ends, axis=1)
    return ends[:, ::2]               # every vertex is the end of two of the face's edges


def face_edges(dm: PETSc.DMPlex, points: IntArray) -> IntArray:
    """Edge points ``(k, m)`` of the face points among ``points`` (others ignored)."""
    fs, fe = dm.getDepthStratum(2)
    faces = points[(points >= fs) & (points < fe)]
    if len(faces) == 0:
        return np.zeros((0, 0), np.int64)
    return cones(dm, faces, dm.getConeSize(int(faces[0])))


def build_serial(raw: RawMesh, comm: PETSc.Comm) -> tuple[PETSc.DMPlex, IntArray]:
    """DMPlex of the 3-D mesh ``raw`` on rank 0 (empty elsewhere), interpolated, with the
    labels of its groups and the boundary faces marked; returns it and the input node
    of every point (-1 for cells and faces)."""
    el = element(raw.cell_type)
    nv = el.nv
    if comm.rank == 0:
        vnodes = raw.vertex_nodes
        vindex = np.full(len(raw.points), -1, dtype=np.int64)
        vindex[vnodes] = np.arange(len(vnodes))
        coords = raw.points[vnodes]
        cells = vindex[raw.cells[:, PLEX_VERTICES[raw.cell_type]]]
    else:
        coords, cells = np.zeros((0, 3)), np.zeros((0, nv), np.int64)
    dm = PETSc.DMPlex().createFromCellList(3, cells.astype(PETSc.IntType), coords, interpolate=True,
                                           comm=comm)
    dm.setName("mesh")
    pstart, pend = dm.getChart()
    node_of_point = np.full(pend - pstart, -1, dtype=np.int64)
    if comm.rank == 0:
        vs, ve = dm.getDepthStratum(0)
        es, ee = dm.getDepthStratum(1)
        node_of_point[vs:ve] = vnodes
        edge_vertices = cones(dm, np.arange(es, ee), 2) - vs              # (ne, 2) vertex indices
        cell_edges = raw.cells[:, el.edges]                              # (nc, nec, 3)
        ends = vindex[cell_edges[..., :2]].reshape(-1, 2)
        which = match_rows(ends, edge_vertices)
        if (which < 0).any() or len(edge_vertices) != len(np.unique(which)):
            raise MeshError(f"{raw.source}: the cells' edges do not match DMPlex's (a cell with "
                            f"a repeated vertex?)")
        node_of_point[es + which] = cell_edges[..., 2].ravel()
        _label_groups(dm, raw, vnodes, vindex, node_of_point, edge_vertices)
    dm.createLabel(_BOUNDARY)
    dm.markBoundaryFaces(_BOUNDARY, 1)
    return dm, node_of_point


def _label_groups(dm: PETSc.DMPlex, raw: RawMesh, vnodes: IntArray, vindex: IntArray,
                  node_of_point: IntArray, edge_vertices: IntArray) -> None:
    """One DMLabel per mesh group (value 1) on rank 0: cells, faces, edges, nodes."""
    cs, _ = dm.getHeightStratum(0)
    vs, _ = dm.getDepthStratum(0)
    es, ee = dm.getDepthStratum(1)
    fs, fe = dm.getDepthStratum(2)
    point_of_node = np.full(len(raw.points), -1, dtype=np.int64)
    point_of_node[vnodes] = np.arange(vs, vs + len(vnodes))
    point_of_node[node_of_point[es:ee]] = np.arange(es, ee)
    face_vertices = None
    for name in raw.group_names():
        label = name if name not in _INTERNAL_LABELS else f"group:{name}"
        entities: list[IntArray] = []
        if name in raw.cell_groups:
            entities.append(cs + np.asarray(raw.cell_groups[name], dtype=np.int64))
        if name in raw.face_groups:
            if face_vertices is None:
                nef = dm.getConeSize(fs) if fe > fs else 0
                face_vertices = _face_vertices(dm, np.arange(fs, fe), nef, edge_vertices + vs) - vs
            nvf = {6: 3, 8: 4}[raw.face_groups[name].shape[1]]
            rows = vindex[raw.face_groups[name][:, :nvf]]
            which = match_rows(rows, face_vertices) if (rows >= 0).all() else np.full(len(rows), -1)
            if (which < 0).any():
                raise MeshError(f"{raw.source}: group {name}: faces that are not faces of any cell")
            entities.append(fs + which)
        if name in raw.edge_groups:
            rows = vindex[np.asarray(raw.edge_groups[name])[:, :2]]
            which = match_rows(rows, edge_vertices) if (rows >= 0).all() else np.full(len(rows), -1)
            if (which < 0).any():
                raise MeshError(f"{raw.source}: group {name}: edges that are not edges of any cell")
            entities.append(es + which)
        dm.createLabel(label)
        lab = dm.getLabel(label)
        if entities:
            set_stratum(lab, ENTITY, np.concatenate(entities))
        if name in raw.node_groups:
            p = point_of_node[np.asarray(raw.node_groups[name], dtype=np.int64)]
            set_stratum(lab, NODE, p[p >= 0])


def group_faces(dm: PETSc.DMPlex, el: Element, node_of_point: IntArray, cell_nodes: IntArray,
                points: IntArray) -> tuple[IntArray, IntArray, IntArray]:
    """The faces among DMPlex ``points`` this process integrates on, given the local
    node of each point and the local nodes ``(nc, nn)`` of the local cells: see
    :meth:`xfemcontact.mesh.plex.LocalMesh.group_faces`.  A face belongs to the
    process owning its point."""
    fs, fe = dm.getDepthStratum(2)
    faces = points[(points >= fs) & (points < fe)]
    faces = faces[~np.isin(faces, point_sf_leaves(dm))]
    nvf = el.faces.shape[1] // 2
    empty = (np.zeros((0, el.faces.shape[1]), np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64))
    if len(faces) == 0:
        return empty
    vertex_nodes = node_of_point[_face_vertices(dm, faces, dm.getConeSize(int(faces[0])))]
    cell_faces = cell_nodes[:, el.faces[:, :nvf]].reshape(-1, nvf)             # (nc * nf, nvf)
    which = match_rows(vertex_nodes, cell_faces)
    keep = which >= 0
    cell, local = np.divmod(which[keep], len(el.faces))
    return cell_nodes[cell[:, None], el.faces[local]].astype(np.int64), cell, local
