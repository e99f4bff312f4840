"""The mesh in DMPlex, distributed over the processes, and its NumPy view per process.

Vertices, edges (faces in 3-D) and cells of the quadratic mesh are DMPlex points:
a vertex point carries a corner node, an edge point carries the mid-edge node, so a
QUAD8, TRIA6, HEXA20 or TETRA10 cell's nodes are exactly the vertex and edge points
of its closure (3-D faces carry no node).  Mesh groups are DMLabels named like the
groups (value 1): cell groups label cells, face groups faces, edge groups edges,
node groups label vertices or edges.  A nodal field (coordinates of
every node, mid-edge nodes included, and the node's index in the input mesh) and
a cell field (the cell's index in the input mesh) are distributed with the mesh,
so that curved edges survive distribution and every decision that must not
depend on the partition can be keyed by input indices.

Partitioning: METIS (pymetis, cut cells weighted, see
:mod:`xfemcontact.mesh.partition`) by default; any PETSc partitioner with
``-petscpartitioner_type ptscotch|simple``.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any, Callable, Literal, Sequence

import numpy as np

from xfemcontact._petsc import PETSc
from xfemcontact.errors import MeshError
from xfemcontact.fem.elements import affine_cells, element

if TYPE_CHECKING:
    import ctypes

    from numpy.typing import NDArray

    from xfemcontact.fem.elements import Element
    from xfemcontact.mesh.raw import RawMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]
    #: DMPlexCreateFromDAG through ctypes, False where it cannot be found
    DagFunction = Callable[..., int] | Literal[False]

from xfemcontact.mesh.labels import _BOUNDARY, _INTERNAL_LABELS, ENTITY, NODE  # noqa: F401
from xfemcontact.mesh.labels import point_sf_leaves, set_stratum as _set_stratum  # noqa: F401


def _edge_keys(a: IntArray, b: IntArray, n: int) -> IntArray:
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    return lo.astype(np.int64) * n + hi


def _build_serial(raw: RawMesh, comm: PETSc.Comm) -> tuple[PETSc.DMPlex, IntArray]:
    """DMPlex of ``raw`` on rank 0 (empty elsewhere), with labels and boundary marks."""
    if raw.dim == 3:
        from xfemcontact.mesh.plex3d import build_serial

        return build_serial(raw, comm)
    nv = raw.n_vertices_per_cell
    dag: _EdgeDag | None
    if comm.rank == 0:
        vnodes = raw.vertex_nodes
        vindex = np.full(len(raw.points), -1, dtype=np.int64)
        vindex[vnodes] = np.arange(len(vnodes))
        coords = raw.points[vnodes]
        dag = _edge_dag(raw, vindex, len(vnodes))
    else:
        coords, dag = np.zeros((0, 2)), _EdgeDag.empty(element(raw.cell_type).edges.shape[0])
    create = _dag_function()
    if create:
        dm = _create_from_dag(comm, dag, coords, create)
    else:               # petsc4py's own (slower) interpolation numbers the edges itself
        cells = (vindex[raw.cells[:, :nv]] if comm.rank == 0 else np.zeros((0, nv))).astype(np.int32)
        dm = PETSc.DMPlex().createFromCellList(2, cells, coords, interpolate=True, comm=comm)
        dag = None
    dm.setName("mesh")
    if comm.rank == 0:
        node_of_point, cones = _match_nodes(dm, raw, vnodes, vindex, dag)
        _label_groups(dm, raw, vnodes, vindex, node_of_point, cones)
    else:
        node_of_point = np.full(dm.getChart()[1] - dm.getChart()[0], -1, dtype=np.int64)
    dm.createLabel(_BOUNDARY)
    dm.markBoundaryFaces(_BOUNDARY, 1)
    return dm, node_of_point


@dataclass
class _EdgeDag:
    """The edges of a mesh, numbered as DMPlex's interpolation numbers them (in the
    order cells first reach them).  Edge ``i`` of a cell runs from its vertex ``i``
    to vertex ``i + 1``."""

    cell_edges: IntArray      # (nc, nec) edge index of each cell edge
    orientation: IntArray     # (nc, nec) 0 if the cell runs along the edge's cone, -1 if against
    cones: IntArray           # (ne, 2) vertex indices (into the vertex nodes) of each edge

    @classmethod
    def empty(cls, nec: int) -> _EdgeDag:
        """No cells (ranks other than 0 before distribution)."""
        return cls(np.zeros((0, nec), np.int64), np.zeros((0, nec), np.int64), np.zeros((0, 2), np.int64))


def _edge_dag(raw: RawMesh, vindex: IntArray, nvert: int) -> _EdgeDag:
    ed = raw.cells[:, element(raw.cell_type).edges]                  # (nc, nec, 3): a, b, mid
    a, b = vindex[ed[..., 0]], vindex[ed[..., 1]]
    keys = _edge_keys(a, b, nvert).ravel()
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")                          # first-reached order
    number = np.empty_like(order)
    number[order] = np.arange(len(order))
    cell_edges = number[inverse].reshape(a.shape)
    cones = np.c_[a.ravel()[first[order]], b.ravel()[first[order]]]
    orientation = np.where(a == cones[cell_edges, 0], 0, -1)
    return _EdgeDag(cell_edges, orientation, cones)


def _dag_function() -> DagFunction:
    """``DMPlexCreateFromDAG`` from the PETSc library petsc4py is linked to, or False.

    petsc4py 3.18 does not wrap it; building the interpolated DAG ourselves (the
    edges are known from the quadratic cells) is 4 to 6 times faster than
    ``createFromCellList(interpolate=True)`` on large meshes.
    """
    global _DAG_FUNCTION
    if _DAG_FUNCTION is None:
        import ctypes
        fn: DagFunction
        try:
            found = ctypes.CDLL(PETSc.__file__).DMPlexCreateFromDAG
            found.restype = ctypes.c_int
            argtypes: list[type[ctypes._SimpleCData[Any]]] = [ctypes.c_void_p, _ctype_int()]
            found.argtypes = argtypes + [ctypes.c_void_p] * 5
            fn = found
        except (OSError, AttributeError, TypeError):
            fn = False
        _DAG_FUNCTION = fn
    return _DAG_FUNCTION


_DAG_FUNCTION: DagFunction | None = None


def _ctype_int() -> type[ctypes._SimpleCData[int]]:
    import ctypes
    return {4: ctypes.c_int32, 8: ctypes.c_int64}[np.dtype(PETSc.IntType).itemsize]


def _create_from_dag(comm: PETSc.Comm, dag: _EdgeDag, coords: FloatArray,
                     create: Callable[..., int]) -> PETSc.DMPlex:
    """Interpolated DMPlex (cells, then vertices, then edges) from an :class:`_EdgeDag`;
    ``create``: DMPlexCreateFromDAG (:func:`_dag_function`)."""
    it = PETSc.IntType
    (nc, nec), nvert, ne = dag.cell_edges.shape, len(coords), len(dag.cones)
    sizes = np.r_[np.full(nc, nec), np.zeros(nvert, int), np.full(ne, 2)].astype(it)
    cones = np.r_[(dag.cell_edges + nc + nvert).ravel(), (dag.cones + nc).ravel()].astype(it)
    orient = np.r_[dag.orientation.ravel(), np.zeros(2 * ne, int)].astype(it)
    counts = np.array([nvert, ne, nc], dtype=it)
    xyz = np.ascontiguousarray(coords, dtype=PETSc.ScalarType)
    dm = PETSc.DMPlex().create(comm=comm)
    dm.setDimension(2)
    ptr = [x.ctypes.data for x in (counts, sizes, cones, orient, xyz)]
    if create(dm.handle, 2, *ptr) != 0:
        raise MeshError("DMPlexCreateFromDAG failed (PETSc printed the reason above)")
    return dm


def _match_nodes(dm: PETSc.DMPlex, raw: RawMesh, vnodes: IntArray, vindex: IntArray,
                 dag: _EdgeDag | None = None) -> tuple[IntArray, IntArray]:
    """Input node index of every vertex and edge point (-1 for cells), and the
    ``(ne, 2)`` vertex indices (into ``vnodes``) of every edge point.

    DMPlex's interpolation makes edge ``i`` of a cell's cone the edge from its
    vertex ``i`` to vertex ``i + 1``: the cell's mid-edge node ``nv + i``.
    ``dag``: the :class:`_EdgeDag` the DMPlex was built from, if it was.
    """
    pstart, pend = dm.getChart()
    vs, ve = dm.getDepthStratum(0)
    cs, ce = dm.getHeightStratum(0)
    es, ee = dm.getDepthStratum(1)
    node_of_point = np.full(pend - pstart, -1, dtype=np.int64)
    node_of_point[vs:ve] = vnodes
    el = element(raw.cell_type)
    if dag is not None:
        cell_edges = dag.cell_edges + es
    else:     # one cone per cell: the only per-cell PETSc call of the mesh build
        cell_edges = np.array([dm.getCone(c) for c in range(cs, ce)], dtype=np.int64).reshape(ce - cs, -1)
    ed = raw.cells[:, el.edges]                                   # (nc, nedges, 3): a, b, mid
    node_of_point[cell_edges] = ed[..., 2]
    cones = np.empty((ee - es, 2), dtype=np.int64)
    cones[cell_edges - es] = vindex[ed[..., :2]]
    probe = int(cell_edges[-1, -1]) if len(cell_edges) else None
    if probe is not None and set(dm.getCone(probe) - vs) != set(cones[probe - es]):
        raise MeshError(f"{raw.source}: unexpected DMPlex edge order")   # PETSc changed its convention
    return node_of_point, cones


def _label_groups(dm: PETSc.DMPlex, raw: RawMesh, vnodes: IntArray, vindex: IntArray,
                  node_of_point: IntArray, cone: IntArray) -> None:
    """One DMLabel per mesh group (value 1) on rank 0."""
    cs, ce = dm.getHeightStratum(0)
    vs = dm.getDepthStratum(0)[0]
    es, ee = dm.getDepthStratum(1)
    nvert = len(vnodes)
    edge_nodes = node_of_point[es:ee]
    # node index -> point (vertex or edge)
    point_of_node = np.full(len(raw.points), -1, dtype=np.int64)
    point_of_node[vnodes] = np.arange(vs, vs + nvert)
    point_of_node[edge_nodes] = np.arange(es, ee)
    ekeys = _edge_keys(cone[:, 0], cone[:, 1], nvert)
    order = np.argsort(ekeys)
    for name in raw.group_names():
        label = name if name not in _INTERNAL_LABELS else f"group:{name}"
        entities: list[IntArray] = []
        if name in raw.cell_groups:
            entities.append(cs + np.asarray(raw.cell_groups[name], dtype=np.int64))
        if name in raw.edge_groups:
            seg = np.asarray(raw.edge_groups[name])
            a, b = vindex[seg[:, 0]], vindex[seg[:, 1]]
            if (a < 0).any() or (b < 0).any():
                raise MeshError(f"{raw.source}: group {name}: edges whose ends are not cell vertices")
            k = _edge_keys(a, b, nvert)
            pos = np.searchsorted(ekeys, k, sorter=order)
            pos = order[np.minimum(pos, len(order) - 1)]
            if not np.array_equal(ekeys[pos], k):
                raise MeshError(f"{raw.source}: group {name}: edges that are not edges of any cell")
            entities.append(es + pos)
        dm.createLabel(label)
        lab = dm.getLabel(label)
        if entities:
            _set_stratum(lab, ENTITY, np.concatenate(entities))
        if name in raw.node_groups:
            p = point_of_node[np.asarray(raw.node_groups[name], dtype=np.int64)]
            _set_stratum(lab, NODE, p[p >= 0])       # nodes of no cell cannot be DMPlex points


def _nodal_field(dm: PETSc.DMPlex, node_of_point: IntArray, points: FloatArray,
                 data: Sequence[FloatArray], cells: IntArray) -> tuple[PETSc.Section, PETSc.Vec]:
    """Section and Vec carrying (x, y, [z,] input node index, nodal fields...) on
    vertices and edges and (input cell index, input node indices of its nodes)
    on cells: once distributed, every process rebuilds its cells' nodes from
    these without walking DMPlex closures one cell at a time."""
    pstart, pend = dm.getChart()
    sec = PETSc.Section().create(comm=dm.comm)
    sec.setChart(pstart, pend)
    nn = cells.shape[1]
    dim = points.shape[1]
    dofs = _field_dofs(dm, len(data), nn, dim)
    list(map(sec.setDof, range(pstart, pend), dofs.tolist()))
    sec.setUp()
    vec = PETSc.Vec().createSeq(sec.getStorageSize(), comm=PETSc.COMM_SELF)
    if pend > pstart:
        cs, ce = dm.getHeightStratum(0)
        off = _field_offsets(dofs)
        a = vec.getArray()
        a[off[cs:ce]] = np.arange(ce - cs)
        a[off[cs:ce, None] + 1 + np.arange(nn)] = cells
        nodes = np.nonzero(node_of_point >= 0)[0]
        n = node_of_point[nodes]
        for c in range(dim):
            a[off[nodes] + c] = points[n, c]
        a[off[nodes] + dim] = n
        for j, f in enumerate(data):
            a[off[nodes] + dim + 1 + j] = f[n]
    return sec, vec


def _field_dofs(dm: PETSc.DMPlex, nfields: int, nn: int, dim: int) -> IntArray:
    """Entries of the nodal field per point: coordinates, node index and fields on
    vertices and edges, 1 + nn on cells, none on 3-D faces."""
    pstart, pend = dm.getChart()
    dofs = np.zeros(pend - pstart, dtype=np.int64)
    for depth in (0, 1):
        start, end = dm.getDepthStratum(depth)
        dofs[start - pstart:end - pstart] = dim + 1 + nfields
    cs, ce = dm.getHeightStratum(0)
    dofs[cs - pstart:ce - pstart] = 1 + nn
    return dofs


def _field_offsets(dofs: IntArray) -> IntArray:
    return np.concatenate([[0], np.cumsum(dofs)[:-1]])


def _partition(dm: PETSc.DMPlex, raw: RawMesh, comm: PETSc.Comm,
               cell_weights: IntArray | None) -> dict[str, Any]:
    """Choose the partitioner: the user's PETSc one, or METIS.  Returns a summary."""
    opts = PETSc.Options()
    part = dm.getPartitioner()
    if opts.hasName("petscpartitioner_type"):
        part.setFromOptions()
        return {"partitioner": part.getType()}
    from xfemcontact.mesh import partition

    verts = raw.cells[:, :raw.n_vertices_per_cell]          # no cells on ranks other than 0
    weights = cell_weights if cell_weights is not None else np.ones(len(verts), np.int64)
    el = element(raw.cell_type)
    sides = el.faces[:, :el.faces.shape[1] // 2] if el.dim == 3 else None
    sizes, load = partition.shell_partition(dm, verts, weights, comm, sides)
    return {"partitioner": "metis", "cells": sizes, "weight": load}


@dataclass
class LocalMesh:
    """What one process holds of the mesh, as arrays for vectorised kernels.

    Local node ``i`` is the DMPlex point ``node_points[i]`` (vertices first, then
    edges); ``cell_nodes`` uses our node order (vertices counter-clockwise, then
    mid-edge nodes).  The index arrays are int32 when the indices fit (half the
    memory, :func:`_index_type`), int64 otherwise; both are typed ``IntArray``.
    """

    dm: PETSc.DMPlex | None    # None once released (release_topology)
    cell_type: str
    cells: IntArray            # (nc,) DMPlex cell points
    cell_nodes: IntArray       # (nc, nn) local node indices
    cell_ids: IntArray         # (nc,) cell index in the input mesh
    node_points: IntArray      # (n,) DMPlex point of each local node
    node_of_point: IntArray    # (chart,) local node of each point, -1 for cells
    x: FloatArray              # (n, dim) node coordinates, m
    node_ids: IntArray         # (n,) node index in the input mesh
    node_owned: BoolArray      # (n,) bool, this process owns the node's point
    n_vertices: int            # local nodes [0, n_vertices) are vertices
    source: str = ""
    partition: dict[str, Any] | None = None         # partitioner and load balance
    node_data: dict[str, FloatArray] | None = None  # nodal fields of the mesh file, name -> (n,)

    def __post_init__(self) -> None:
        # kept when the DMPlex is released (release_topology): the communicator, the
        # chart and the point star forest (node reductions between processes)
        dm = self.plex
        self._comm: PETSc.Comm = dm.comm
        self.chart: tuple[int, int] = dm.getChart()
        self.point_sf: PETSc.SF | None = dm.getPointSF() if self._comm.size > 1 else None

    @property
    def comm(self) -> PETSc.Comm:
        return self._comm

    @property
    def plex(self) -> PETSc.DMPlex:
        """The DMPlex (mesh groups, cones and supports) until :meth:`release_topology`."""
        if self.dm is None:
            raise AttributeError("the mesh's DMPlex was released (release_topology)")
        return self.dm

    def release_topology(self) -> None:
        """Destroy the DMPlex (cones, supports, labels, coordinates: 27 MB at 410k
        nodes) once the set-up is done: the solve and the post-processing use the
        arrays of this object only.  Mesh groups cannot be asked for afterwards."""
        if self.dm is not None:
            self.dm.destroy()
            self.dm = None

    @property
    def element(self) -> Element:
        return element(self.cell_type)

    @property
    def dim(self) -> int:
        """Space dimension (2 or 3)."""
        return self.element.dim

    def cell_coordinates(self) -> FloatArray:
        """``(nc, nn, dim)`` node coordinates of every local cell."""
        return self.x[self.cell_nodes]

    @cached_property
    def affine(self) -> BoolArray:
        """``(nc,)`` bool: cells with an affine map (:func:`elements.affine_cells`)."""
        el, n = self.element, len(self.cells)
        step = 65536            # bounded temporaries
        return np.concatenate([affine_cells(el, self.x[self.cell_nodes[s:s + step]])
                               for s in range(0, n, step)]) if n else np.zeros(0, bool)

    # -- groups -------------------------------------------------------------
    def group_names(self) -> list[str]:
        dm = self.plex
        names = [dm.getLabelName(i) for i in range(dm.getNumLabels())]
        return sorted(n.removeprefix("group:") for n in names if n not in _INTERNAL_LABELS)

    def has_group(self, name: str) -> bool:
        return name in self.group_names()

    def _label(self, name: str) -> str:
        return name if name not in _INTERNAL_LABELS else f"group:{name}"

    def group_points(self, name: str, value: int = ENTITY) -> IntArray:
        """Local DMPlex points of group ``name``: its cells and edges (``ENTITY``)
        or the points carrying its nodes (``NODE``)."""
        label = self._label(name)
        if not self.plex.hasLabel(label):
            raise KeyError(name)
        return self._stratum(label, value)

    def _stratum(self, label: str, value: int = ENTITY) -> IntArray:
        dm = self.plex
        if dm.getStratumSize(label, value) == 0:
            return np.zeros(0, np.int64)
        iset = dm.getStratumIS(label, value)
        return np.asarray(iset.getIndices(), dtype=np.int64) if iset.getSize() else np.zeros(0, np.int64)

    def group_nodes(self, name: str) -> IntArray:
        """Local nodes of group ``name``: nodes of its cells, faces and edges, and its nodes."""
        pts = self.group_points(name)
        cs, ce = self.plex.getHeightStratum(0)
        is_cell = (pts >= cs) & (pts < ce)
        nodes = [self.node_of_point[self.group_points(name, NODE)]]
        if is_cell.any():
            cell_index = np.searchsorted(self.cells, pts[is_cell])
            nodes.append(self.cell_nodes[cell_index].ravel())
        edges = self._edge_points(pts[~is_cell])
        if self.dim == 3:
            from xfemcontact.mesh import plex3d

            edges = np.r_[edges, plex3d.face_edges(self.plex, pts[~is_cell]).ravel()]
        if len(edges):
            nodes.append(self.edge_nodes(edges).ravel())
        return np.unique(np.concatenate(nodes)).astype(np.int64)

    def group_edge_nodes(self, name: str) -> IntArray:
        """``(k, 3)`` nodes of every local edge of group ``name`` (shared ones too)."""
        return self.edge_nodes(self._edge_points(self.group_points(name)))

    def _edge_points(self, pts: IntArray) -> IntArray:
        es, ee = self.plex.getDepthStratum(1)
        return pts[(pts >= es) & (pts < ee)]

    def edge_nodes(self, edges: IntArray) -> IntArray:
        """``(k, 3)`` local nodes (a, b, mid) of edge points ``edges``."""
        dm = self.plex
        cone = np.array([dm.getCone(e) for e in edges], dtype=np.int64).reshape(-1, 2)
        return np.c_[self.node_of_point[cone], self.node_of_point[edges]]

    def group_edges(self, name: str) -> tuple[IntArray, IntArray, IntArray]:
        """Edges of group ``name`` this process integrates on (each edge once overall).

        Returns ``(nodes (k, 3), cell (k,), local_edge (k,))``: the edge's nodes
        (a, b, mid) oriented like the cell ``cell`` (local cell index) that holds
        it as its edge ``local_edge``, so that the outward normal of the cell is
        to the right of a -> b.
        """
        edges = self._edge_points(self.group_points(name))
        owned = self.node_owned[self.node_of_point[edges]]
        edges = edges[owned]
        cell_of_edge, local = self._edge_cells(edges)
        keep = cell_of_edge >= 0
        edges, cell_of_edge, local = edges[keep], cell_of_edge[keep], local[keep]
        el = self.element
        nodes = self.cell_nodes[cell_of_edge[:, None], el.edges[local]]
        return nodes, cell_of_edge, local

    def _edge_cells(self, edges: IntArray) -> tuple[IntArray, IntArray]:
        """A local cell holding each edge and the edge's index in it (-1 if none)."""
        dm = self.plex
        cell = np.full(len(edges), -1, dtype=np.int64)
        local = np.zeros(len(edges), dtype=np.int64)
        for k, e in enumerate(edges):
            for c in dm.getSupport(e):
                idx = np.searchsorted(self.cells, c)
                if idx < len(self.cells) and self.cells[idx] == c:
                    cone = list(dm.getCone(c))
                    cell[k], local[k] = idx, cone.index(e)
                    break
        return cell, local

    def group_faces(self, name: str) -> tuple[IntArray, IntArray, IntArray]:
        """Faces of 3-D group ``name`` this process integrates on (each face once overall).

        Returns ``(nodes (k, nf), cell (k,), local_face (k,))``: the face's nodes in
        its element's order (QUAD8, TRIA6) oriented like the face ``local_face`` of the
        local cell ``cell``, so that the right-hand rule gives the outward normal.
        """
        from xfemcontact.mesh import plex3d

        return plex3d.group_faces(self.plex, self.element, self.node_of_point, self.cell_nodes,
                                  self.group_points(name))

    def boundary_edges(self) -> IntArray:
        """Nodes ``(k, 3)`` of domain-boundary edges held by local cells (all of them)."""
        edges = self._edge_points(self._stratum(_BOUNDARY))
        cell, local = self._edge_cells(edges)
        keep = cell >= 0
        return self.cell_nodes[cell[keep][:, None], self.element.edges[local[keep]]]


def load(raw: RawMesh | None, comm: PETSc.Comm | None = None,
         cell_weights: IntArray | None = None) -> LocalMesh:
    """Build the DMPlex of ``raw`` (significant on rank 0), distribute it, return a LocalMesh.

    ``raw`` may be None on ranks other than 0; ``cell_weights`` (rank 0) weight the
    METIS partition.
    """
    comm = comm or PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    meta = None
    if mpi.rank == 0:
        assert raw is not None, "the input mesh is significant on rank 0"
        meta = (raw.cell_type, raw.source, sorted(raw.point_data), len(raw.cells), len(raw.points))
    cell_type, source, field_names, ncells, nnodes = mpi.bcast(meta, root=0)
    from xfemcontact import resources

    resources.check_cells(cell_type, ncells, comm.size, source, nodes=nnodes)   # before the DMPlex
    if raw is None or mpi.rank != 0:
        raw = _no_cells(cell_type, source)
    dm, node_of_point = _build_serial(raw, comm)
    data = [raw.point_data[k] for k in field_names] if mpi.rank == 0 else [np.zeros(0)] * len(field_names)
    sec, vec = _nodal_field(dm, node_of_point, raw.points, data, raw.cells)
    part_info: dict[str, Any] = {"partitioner": "none"}
    if comm.size > 1:
        part_info = _partition(dm, raw, comm, cell_weights)
        sf = dm.distribute()
        if sf is not None:
            newsec, newvec = dm.distributeField(sf, sec, vec)
            sec, vec = newsec, newvec
    mesh = _local_view(dm, sec, vec, cell_type, source, field_names)
    counts = comm.tompi4py().allgather(len(mesh.cells))
    part_info["cells_per_process"] = counts
    part_info["imbalance"] = max(counts) / (sum(counts) / len(counts)) if sum(counts) else 1.0
    mesh.partition = part_info
    return mesh


def _no_cells(cell_type: str, source: str) -> RawMesh:
    """Stands for the RawMesh on ranks other than 0 (which hold no cells)."""
    from xfemcontact.mesh.raw import RawMesh

    return RawMesh(points=np.zeros((0, element(cell_type).dim)), cell_type=cell_type,
                   cells=np.zeros((0, element(cell_type).nn), np.int64), source=source)


def _local_view(dm: PETSc.DMPlex, sec: PETSc.Section, vec: PETSc.Vec, cell_type: str, source: str,
                field_names: Sequence[str] = ()) -> LocalMesh:
    pstart, pend = dm.getChart()
    cs, ce = dm.getHeightStratum(0)
    vs, ve = dm.getDepthStratum(0)
    es, ee = dm.getDepthStratum(1)
    el = element(cell_type)
    dim = el.dim
    node_points = np.r_[np.arange(vs, ve), np.arange(es, ee)].astype(np.int64)
    node_of_point = np.full(pend - pstart, -1, dtype=np.int64)
    node_of_point[node_points] = np.arange(len(node_points))
    cells = np.arange(cs, ce, dtype=np.int64)
    dofs = _field_dofs(dm, len(field_names), el.nn, dim)
    off = _field_offsets(dofs)
    if sec.getChart()[1] > sec.getChart()[0] and pend > pstart:
        probe = node_points[-1] if len(node_points) else cs
        assert sec.getOffset(int(probe)) == off[probe], "unexpected section layout"
    a = vec.getArray(readonly=True)
    noff = off[node_points]
    x = np.stack([a[noff + c] for c in range(dim)], axis=1) if len(noff) else np.zeros((0, dim))
    node_ids = a[noff + dim].astype(np.int64) if len(noff) else np.zeros(0, np.int64)
    cell_ids = a[off[cells]].astype(np.int64) if len(cells) else np.zeros(0, np.int64)
    cell_nodes = _local_cell_nodes(a[off[cells][:, None] + 1 + np.arange(el.nn)].astype(np.int64), node_ids)
    node_data = {name: (a[noff + dim + 1 + j] if len(noff) else np.zeros(0)) for j, name in enumerate(field_names)}
    owned = np.ones(pend - pstart, dtype=bool)
    leaves = point_sf_leaves(dm)
    owned[leaves] = False
    # the index arrays kept for the whole run in 32-bit integers when they fit (half the memory)
    it = _index_type(max(pend, int(node_ids.max(initial=0)) + 1, int(cell_ids.max(initial=0)) + 1))
    cells, cell_nodes, cell_ids = cells.astype(it), cell_nodes.astype(it), cell_ids.astype(it)
    node_points, node_of_point, node_ids = node_points.astype(it), node_of_point.astype(it), node_ids.astype(it)
    return LocalMesh(dm=dm, cell_type=cell_type, cells=cells, cell_nodes=cell_nodes,
                     cell_ids=cell_ids, node_points=node_points, node_of_point=node_of_point,
                     x=x, node_ids=node_ids, node_owned=owned[node_points],
                     n_vertices=ve - vs, source=source, node_data=node_data)


def _index_type(bound: int) -> type[np.int32] | type[np.int64]:
    """int32 for indices below ``bound`` when it fits, else int64."""
    return np.int32 if bound < np.iinfo(np.int32).max else np.int64


def _local_cell_nodes(cell_input_nodes: IntArray, node_ids: IntArray) -> IntArray:
    """Local node indices ``(nc, nn)`` of cells given by input node indices: every
    node of a local cell is a local point (DMPlex distributes closures)."""
    order = np.argsort(node_ids, kind="stable")
    pos = np.searchsorted(node_ids[order], cell_input_nodes)
    pos = np.minimum(pos, max(len(order) - 1, 0))
    found = order[pos] if len(order) else np.zeros(cell_input_nodes.shape, np.int64)
    if len(order) and not np.array_equal(node_ids[found], cell_input_nodes):
        raise MeshError("distributed mesh: a cell node is missing on its process")
    return found


def reduce_nodes(mesh: LocalMesh, values: NDArray[Any], op: str = "sum") -> Any:
    """Combine per-node ``values (n, ...)`` over every process holding the node.

    ``op``: "sum", "max" or "min".  Each process gets the combined value at its
    nodes (owners reduce the copies of the other processes, then broadcast): an
    array of the dtype and shape of ``values`` (typed Any: callers convert it).
    """
    values = np.ascontiguousarray(values)
    if mesh.comm.size == 1:
        return values.copy()
    if values.ndim > 1:          # one column at a time: MPI reductions need basic types
        flat = values.reshape(len(values), int(np.prod(values.shape[1:])))
        cols = [reduce_nodes(mesh, np.ascontiguousarray(flat[:, j]), op) for j in range(flat.shape[1])]
        return np.stack(cols, axis=1).reshape(values.shape)
    from mpi4py import MPI

    mpi_op = {"sum": MPI.SUM, "max": MPI.MAX, "min": MPI.MIN}[op]
    unit = MPI._typedict[values.dtype.char]
    nchart = mesh.chart[1]
    data = np.zeros(nchart, dtype=values.dtype)
    data[mesh.node_points] = values
    leaf = data.copy()
    root = data.copy()
    if op == "sum":
        root[mesh.node_points[~mesh.node_owned]] = 0   # a ghost's value reaches its owner through the SF
    sf = mesh.point_sf
    assert sf is not None                  # several processes
    sf.reduceBegin(unit, leaf, root, mpi_op)
    sf.reduceEnd(unit, leaf, root, mpi_op)
    out = root.copy()
    sf.bcastBegin(unit, root, out, MPI.REPLACE)
    sf.bcastEnd(unit, root, out, MPI.REPLACE)
    return out[mesh.node_points]
