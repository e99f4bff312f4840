"""The post-processing mesh, like code_aster's POST_MAIL_XFEM + POST_CHAM_XFEM.

* uncut cells are kept as they are (QUAD8, TRIA6; HEXA20, TETRA10 in 3-D);
* every cut cell is replaced by its 6-node sub-triangles (:mod:`xfemcontact.xfem.cut`;
  in 3-D its 10-node sub-tetrahedra, :mod:`xfemcontact.xfem.cut3d`), whose physical
  nodes are the parent map of their reference nodes;
* a point shared by cells of both sides (a point of the interface: where it
  crosses cell edges, the segment mid-points, mesh nodes with LN = 0) is
  duplicated, one copy per side, so the displacement jump shows.

Point fields: DX, DY, [DZ] (m, the displacement of the point's own side, Heaviside
part included), ``displacement`` (DX, DY, 0 or DZ) for ParaView's *Warp By Vector*,
LAGS_C (Pa) and LAGS_F1 (-) (3-D: and LAGS_F2) at interface points (0 elsewhere), the contact
(1 contact / 0 open) and sliding (1 slip / 0 stick) statuses of the nearest
interface Gauss point (0 elsewhere), and NFISSU: -1 on the copies of the
LN < 0 side (code_aster's "NM" nodes), +1 on those of the LN > 0 side ("NP"),
0 off the interface.

Cell fields: SIXX, SIYY, SIXY (Pa) and EPXX, EPYY, EPXY (tensor shear strain; in 3-D
the six components XX, YY, ZZ, XY, XZ, YZ) averaged over the cell or sub-cell, ``side`` (-1/+1; 0 without interface),
``cell`` (the input cell index) and ``subcell`` (index of the sub-triangle or
sub-tetrahedron in its parent, -1 for uncut cells).

In MED files the interface copies also form node groups NM (LN < 0 side), NP
(LN > 0 side) and NFISSU (both), as POST_MAIL_XFEM names them.

In 3-D the interface surface itself (its curved facets with every interface field) is
a mesh of its own, :attr:`PostMesh.interface` (:mod:`xfemcontact.post.surface`), and
the interface points of this mesh take their multipliers and statuses from it.

Every process computes its own cells; rank 0 gathers them and numbers cells by
(block, input cell, sub-cell) and points by first use, so the files do not
depend on the number of processes.

Connectivities are in meshio's (VTK's) node order, that of XDMF and VTU files: the
mirror image of ours (MED's) for 3-D cells (:func:`meshio_order`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Iterator, cast

import numpy as np

from xfemcontact.assembly import bulk
from xfemcontact.assembly.system import enriched_gradients
from xfemcontact.fem import elasticity
from xfemcontact.fem.elements import element
from xfemcontact.post import fields, surface
from xfemcontact.post.fields import cell_node_displacement, displacement_at
from xfemcontact.post.points import MERGE_TOL, diagonal, merge_points
from xfemcontact.xfem import geometry as xgeo
from xfemcontact.xfem.cut import segment_curve

if TYPE_CHECKING:
    import meshio
    from numpy.typing import NDArray

    from xfemcontact.model import Model
    from xfemcontact.xfem.integration import CellPoints, SegmentPoints

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]
    #: arrays by name, of one length (rows, points or samples)
    Columns = dict[str, NDArray[Any]]

MESHIO_CELL = {"QUAD8": "quad8", "TRIA6": "triangle6", "HEXA20": "hexahedron20", "TETRA10": "tetra10"}
#: interface points of a cut-cell segment: its ends, mid-point and quarter points
SEGMENT_POINTS = np.array([-1.0, -0.5, 0.0, 0.5, 1.0])
#: interface samples farther than this (same unit) from every interface point are not post-mesh points
SAMPLE_TOL = 1e-9
CELL_FIELDS = ("SIXX", "SIYY", "SIXY", "EPXX", "EPYY", "EPXY", "side", "cell", "subcell")
#: the same in 3-D
CELL_FIELDS_3D = ("SIXX", "SIYY", "SIZZ", "SIXY", "SIXZ", "SIYZ",
                  "EPXX", "EPYY", "EPZZ", "EPXY", "EPXZ", "EPYZ", "side", "cell", "subcell")
#: the element of the sub-cells of cut cells, per dimension
SUBCELL = {2: "TRIA6", 3: "TETRA10"}
#: the interface fields of the interface points, per dimension (0 elsewhere)
MULTIPLIER_FIELDS = {2: ("LAGS_C", "LAGS_F1", "contact", "sliding"),
                     3: ("LAGS_C", "LAGS_F1", "LAGS_F2", "contact", "sliding")}
#: Voigt components, per dimension
VOIGT = {2: ("XX", "YY", "XY"), 3: ("XX", "YY", "ZZ", "XY", "XZ", "YZ")}


def meshio_order(cell_type: str) -> IntArray | None:
    """The permutation taking our (MED's) node order of ``cell_type`` to meshio's (VTK's),
    None when they agree (2-D cells).  It is its own inverse."""
    from xfemcontact.fem.elements import element

    el = element(cell_type)
    return el.reverse if el.dim == 3 else None


@dataclass
class PostMesh:
    """The post-processing mesh of the whole model (rank 0)."""

    points: FloatArray                          # (np, d) m
    blocks: list[tuple[str, IntArray]]          # [(meshio cell type, connectivity (k, nn))], quad8 before
                                                # triangle6, in meshio's node order
    point_data: dict[str, NDArray[Any]]         # name -> (np,) (or (np, 3) vectors)
    cell_data: dict[str, list[NDArray[Any]]]    # name -> [(k,) per block]
    interface: PostMesh | None = None           # 3-D: the interface surface (post.surface)

    def point_fields(self) -> Iterator[tuple[str, NDArray[Any]]]:
        """``(name, array)`` of the point fields of the XDMF and VTU files: those of
        :attr:`point_data`, then ``displacement`` (DX, DY, 0 or DZ) for ParaView."""
        yield from self.point_data.items()
        yield "displacement", self.displacement()

    def displacement(self) -> FloatArray:
        """``(np, 3)`` DX, DY and DZ (0 in 2-D), m."""
        pd = self.point_data
        disp = np.zeros((len(self.points), 3))
        disp[:, 0], disp[:, 1] = pd["DX"], pd["DY"]
        if "DZ" in pd:
            disp[:, 2] = pd["DZ"]
        return disp

    def to_meshio(self, med: bool = False) -> meshio.Mesh:
        """A meshio.Mesh: 3-D points and a ``displacement`` vector (for ParaView), or for
        MED (``med``) the points as they are (2-D in 2-D), the cells in MED's node order
        and the node groups NFISSU, NM (LN < 0 copies) and NP."""
        import meshio

        pd = dict(self.point_data)
        blocks = [(t, c) for t, c in self.blocks]
        if med:
            pts = self.points
            nf = pd["NFISSU"]
            pd["point_tags"] = np.where(nf == -1, 1, np.where(nf == 1, 2, 0)).astype(np.int64)
            blocks = [(t, _to_ours(t, c)) for t, c in blocks]
        else:
            pts = np.c_[self.points, np.zeros(len(self.points))] if self.points.shape[1] == 2 else self.points
            pd["displacement"] = self.displacement()
        m = meshio.Mesh(pts, blocks, point_data=pd,
                        cell_data={k: list(v) for k, v in self.cell_data.items()})
        if med:
            m.point_tags = {1: ["NFISSU", "NM"], 2: ["NFISSU", "NP"]}
        return m


def _to_ours(meshio_type: str, conn: IntArray) -> IntArray:
    """Connectivity ``conn`` of meshio type ``meshio_type`` in our (MED's) node order."""
    ours = {v: k for k, v in MESHIO_CELL.items()}.get(meshio_type)
    perm = meshio_order(ours) if ours is not None else None
    return conn if perm is None else conn[:, perm]


# -- one process's cells ---------------------------------------------------------
def _pieces(model: Model, xl: FloatArray) -> Columns:
    """The post cells of this process, as padded arrays.

    Returns a dict: ``cell (m,)`` input ids, ``sub (m,)`` sub-cell index (-1
    uncut), ``nn (m,)`` node count, ``x (m, nn, d)`` node coordinates (m; nn the parent cell's node count),
    ``node (m, nn)`` input node ids (-1 at sub-cell nodes: merged by position),
    ``u (m, nn, d)`` displacements (m), ``side (m,)``, ``sig``, ``eps (m, nv)``.
    """
    mesh, geo, layout = model.mesh, model.geo, model.layout
    el = mesh.element
    nc = len(mesh.cells)
    cut = geo.cell_side == 0 if geo is not None else np.zeros(nc, bool)
    uncut = np.nonzero(~cut)[0]
    side_u = geo.cell_side[uncut] if geo is not None else np.zeros(len(uncut), np.int64)
    eps = fields.cell_mean_strains(mesh, geo, layout, xl)
    sig = eps @ model.D.T
    nodes = mesh.cell_nodes[uncut]
    parts = [dict(cell=mesh.cell_ids[uncut], sub=np.full(len(uncut), -1), nn=np.full(len(uncut), el.nn),
                  x=mesh.x[nodes], node=mesh.node_ids[nodes], u=cell_node_displacement(model, xl, uncut, side_u),
                  side=side_u, sig=sig[uncut], eps=eps[uncut])]
    if cut.any():
        parts.append(_subcell_pieces(model, xl))
    out: Columns = {}
    for k in parts[0]:
        arrs = [p[k] for p in parts]
        if arrs[0].ndim > 1:         # pad nodes to the parent's count (sub-cells have 6)
            arrs = [a if a.shape[1] == el.nn else
                    np.concatenate([a, np.full((len(a), el.nn - a.shape[1]) + a.shape[2:], -1 if k == "node" else 0,
                                               a.dtype)], axis=1) for a in arrs]
        out[k] = arrs[0] if len(arrs) == 1 else np.concatenate(arrs)
    return out


def _subcell_pieces(model: Model, xl: FloatArray) -> Columns:
    """Sub-triangles (3-D: sub-tetrahedra) of the cut cells with their mean stresses and
    strains."""
    mesh, geo = model.mesh, model.geo
    assert geo is not None                     # cut cells: an interface
    parts = [_subcell_group(model, xl, pts) for group in xgeo.cell_points(mesh, geo, geo.subcells.cells)
             for pts in xgeo.chunks(group)]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def _subcell_group(model: Model, xl: FloatArray, pts: CellPoints) -> Columns:
    """:func:`_subcell_pieces` of the cut cells of one batch of quadrature points ``pts``
    (:func:`xfemcontact.xfem.geometry.cell_points`, :func:`~xfemcontact.xfem.geometry.chunks`)."""
    mesh, geo, layout = model.mesh, model.geo, model.layout
    assert geo is not None                     # cut cells: an interface
    el = mesh.element
    rows = np.searchsorted(geo.subcells.cells, pts.cells)
    nodes, sides = geo.subcells.nodes[rows], geo.subcells.side[rows]        # (k, ns, nsn, d), (k, ns)
    k, ns, nsn = nodes.shape[:3]
    nv = 3 * el.dim - 3
    live = sides != 0                                                         # (k, ns)
    cells = np.repeat(pts.cells, ns)[live.ravel()]
    xi = nodes[live]                                                          # (m, nsn, d)
    side = sides[live]
    x = el.map_points(mesh.x[mesh.cell_nodes[cells]], xi)
    ue = xl[bulk.enriched_batch(mesh, layout, pts.cells).local]
    e = elasticity.strain(enriched_gradients(mesh, geo, pts), ue)             # (k, ns nq, nv)
    # the mean with |w|: the same where the sub-cell's Jacobian is positive; where a thin
    # curved sub-tetrahedron folds, its signed volume nearly cancels and the signed mean
    # was off by orders of magnitude (SIZZ 9e14 Pa in a box under 150 Pa)
    w = np.abs(pts.w.reshape(k, ns, -1))                                      # sub-cell major
    vol = w.sum(axis=2)
    area = np.where(vol > 1e-300, vol, 1e-300)[..., None]
    eps = np.einsum("ksq,ksqi->ksi", w, e.reshape(k, ns, -1, nv)) / area      # (k, ns, nv)
    sig = eps @ model.D.T                                                     # linear: mean of D eps
    return dict(cell=mesh.cell_ids[cells], sub=np.nonzero(live)[1], nn=np.full(len(cells), nsn),
                x=x, node=np.full((len(cells), nsn), -1, np.int64), u=displacement_at(model, xl, cells, xi, side),
                side=side, sig=sig[live], eps=eps[live])


def interface_samples(model: Model) -> Columns | None:
    """Multipliers and statuses at the interface points of every local segment
    (its ends, mid-point and quarter points).  Collective (reads remote dofs).

    Returns a dict of flat arrays: x, y (m), cell (input cell id), LAGS_C (Pa),
    LAGS_F1, contact, sliding; None without multipliers (and in 3-D: the facets' nodes of
    :func:`xfemcontact.post.surface.samples` instead).
    """
    problem = model.problem
    if problem is None or problem.space is None or problem.segments is None:
        return None
    mesh, el = model.mesh, model.mesh.element
    segs = problem.segments
    xi, x, _ = segment_curve(el, mesh.x[mesh.cell_nodes[segs.cells]], segs.nodes, SEGMENT_POINTS)
    pts = cast("SegmentPoints", problem.points)          # 2-D: a segments' problem
    near = np.argmin(np.abs(pts.s[None, :] - SEGMENT_POINTS[:, None]), axis=1)   # (5,)
    v = problem.segment_values(model.x, xi, near)
    if v is None:                       # no multipliers (not a contact problem)
        return None
    out = {"x": x[..., 0].ravel(), "y": x[..., 1].ravel(),
           "cell": np.repeat(mesh.cell_ids[segs.cells], len(SEGMENT_POINTS))}
    out.update({k: a.ravel() for k, a in v.items()})
    return out


# -- the whole mesh on rank 0 ----------------------------------------------------------
def build(model: Model) -> PostMesh | None:
    """The PostMesh on rank 0, None elsewhere.  Collective."""
    xl = model.local_solution()
    surf = surface.local_pieces(model, xl)                  # 3-D: the interface facets
    payload = (_pieces(model, xl), interface_samples(model) if surf is None else surface.samples(surf),
               _cut_cell_nodes(model), surf)
    del xl, surf
    mpi = model.comm.tompi4py()
    parts = [payload] if mpi.size == 1 else mpi.gather(payload, root=0)    # one process: no copy
    if parts is None:
        return None
    del payload

    def joined(arrays: list[NDArray[Any]]) -> NDArray[Any]:
        return arrays[0] if len(arrays) == 1 else np.concatenate(arrays)

    pieces = {k: joined([p[0][k] for p in parts]) for k in parts[0][0]}
    samples = None
    if parts[0][1] is not None:
        every = cast("list[Columns]", [p[1] for p in parts])   # every process has samples, or none
        samples = {k: joined([v[k] for v in every]) for k in parts[0][1]}
    near = np.unique(np.concatenate([p[2] for p in parts]))
    facets = None
    if parts[0][3] is not None:                             # every process has facets, or none
        every = cast("list[Columns]", [p[3] for p in parts])
        facets = {k: joined([v[k] for v in every]) for k in every[0]}
    del parts
    post = assemble(pieces, samples, model.mesh.cell_type, near)
    if facets is not None:
        post.interface = PostMesh(*surface.assemble(facets))
    return post


def _cut_cell_nodes(model: Model) -> IntArray:
    """Input ids of the nodes of this process's cut cells: the only input nodes that
    sub-cell nodes can coincide with."""
    geo, mesh = model.geo, model.mesh
    if geo is None:
        return np.zeros(0, np.int64)
    return np.unique(mesh.node_ids[mesh.cell_nodes[geo.cell_side == 0]])


def assemble(pieces: Columns, samples: Columns | None, cell_type: str,
             near: IntArray | None = None) -> PostMesh:
    """Number cells and points of the gathered ``pieces`` (see :func:`_pieces`);
    ``near``: input node ids that sub-cell nodes may coincide with (all if None)."""
    parent = element(cell_type)
    d = parent.dim
    tri = element(SUBCELL[d])                                                 # the sub-cells' element
    block = (pieces["nn"] != parent.nn).astype(int)                           # 1: sub-cells of another type
    if _sorted(block, pieces["cell"], pieces["sub"]):                        # one process, QUAD8
        p = pieces
    else:
        order = np.lexsort((pieces["sub"], pieces["cell"], block))
        p = {k: v[order] for k, v in pieces.items()}
        block = block[order]
    nn = p["nn"]
    slot = np.arange(p["x"].shape[1])[None, :] < nn[:, None]                  # (m, width) live node slots
    xs = p["x"][slot]                                                         # (S, d) in cell order
    side_s = np.repeat(p["side"], nn)
    loc = slot_locations(xs, p["node"][slot], near)
    # a point per (location, side); the interface is where a location has two sides
    key = loc * 3 + (side_s + 1)
    uniq, first, slot_point = np.unique(key, return_index=True, return_inverse=True)
    rank = np.empty(len(uniq), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(uniq))            # number by first use
    slot_point = rank[slot_point]
    pfirst = np.sort(first)
    points = xs[pfirst]
    ploc = loc[pfirst]
    pside = side_s[pfirst]
    nsides = np.bincount(ploc, minlength=ploc.max() + 1 if len(ploc) else 0)
    on_itf = nsides[ploc] > 1
    us = p["u"][slot][pfirst]
    pd = {**{c: us[:, i] for i, c in enumerate(("DX", "DY", "DZ")[:d])},
          **{c: np.zeros(len(points)) for c in MULTIPLIER_FIELDS[d]},
          "NFISSU": np.where(on_itf, pside, 0).astype(np.int64)}
    if samples is not None and on_itf.any():
        _set_interface_values(pd, points, ploc, on_itf, samples)
    conn = np.full(slot.shape, -1, np.int64)
    conn[slot] = slot_point
    blocks: list[tuple[str, IntArray]] = []
    cd: dict[str, list[NDArray[Any]]] = {k: [] for k in (CELL_FIELDS_3D if d == 3 else CELL_FIELDS)}
    types = [cell_type] if cell_type == tri.name else [cell_type, tri.name]
    for b, ours in enumerate(types):
        rows = block == b
        if not rows.any():
            continue
        name = MESHIO_CELL[ours]
        n = element(ours).nn
        perm = meshio_order(ours)
        blocks.append((name, conn[rows, :n] if perm is None else conn[rows][:, perm]))
        sig, eps = p["sig"][rows], p["eps"][rows]
        for i, c in enumerate(VOIGT[d]):
            cd["SI" + c].append(sig[:, i])
            cd["EP" + c].append(eps[:, i] * (0.5 if c[0] != c[1] else 1.0))
        cd["side"].append(p["side"][rows].astype(np.int64))
        cd["cell"].append(p["cell"][rows].astype(np.int64))
        cd["subcell"].append(p["sub"][rows].astype(np.int64))
    return PostMesh(points, blocks, pd, cd)


def _sorted(*keys: NDArray[Any]) -> bool:
    """True when rows are in lexicographic order of ``keys`` (first key first)."""
    if len(keys[0]) < 2:
        return True
    ahead = np.zeros(len(keys[0]) - 1, bool)          # decided: strictly increasing at an earlier key
    for k in keys:
        d = np.diff(k)
        if np.any((d < 0) & ~ahead):
            return False
        ahead |= d > 0
    return True


def slot_locations(xs: FloatArray, node: IntArray, near: IntArray | None = None) -> IntArray:
    """Location label ``(S,)`` of every cell slot, numbered by first appearance.

    Slots with an input node id (``node >= 0``) are that node; the others (sub-cell
    nodes) are merged by position (:func:`merge_points`) among themselves and
    with the nodes of the input mesh that they touch (among the ids ``near``, if
    given: the nodes of the cut cells).
    """
    from scipy.spatial import cKDTree

    key = node.astype(np.int64).copy()
    free = np.nonzero(key < 0)[0]
    if len(free):
        diag = diagonal(xs)
        known = np.nonzero(key >= 0)[0]
        if near is not None and len(known):
            candidate = np.zeros(max(int(key.max()), int(near.max(initial=0))) + 1, bool)
            candidate[near] = True
            known = known[candidate[key[known]]]
        known = known[np.unique(key[known], return_index=True)[1]]          # one slot per input node
        d, _ = cKDTree(xs[free]).query(xs[known], distance_upper_bound=MERGE_TOL * diag)
        known = known[np.isfinite(d)]                                        # input nodes that sub-cells touch
        lab = merge_points(np.concatenate([xs[free], xs[known]]), diag=diag)
        ids = np.full(lab.max() + 1, -1, np.int64)
        ids[lab[len(free):]] = key[known]                                    # groups holding an input node
        fresh = ids < 0
        ids[fresh] = (key.max() + 1 if len(known) else 0) + np.arange(fresh.sum())
        key[free] = ids[lab[:len(free)]]
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[inv]


def _set_interface_values(pd: dict[str, NDArray[Any]], points: FloatArray, ploc: IntArray, on_itf: BoolArray,
                          samples: Columns) -> None:
    """LAGS_C, LAGS_F1 (3-D: LAGS_F2) and statuses at the interface points (every copy),
    from the sample of the lowest input cell at that location; samples at no post-mesh
    point (quarter points of segments lying on cell edges) are ignored."""
    from scipy.spatial import cKDTree

    dim = points.shape[1]
    ip = np.nonzero(on_itf)[0]
    locs, first = np.unique(ploc[ip], return_index=True)
    xy = points[ip[first]]                                                    # one per location
    diag = diagonal(points)
    order = np.argsort(samples["cell"], kind="stable")
    sx = np.stack([samples[c] for c in ("x", "y", "z")[:dim]], axis=1)[order]
    d, j = cKDTree(xy).query(sx, distance_upper_bound=SAMPLE_TOL * diag)
    hit = np.nonzero(np.isfinite(d))[0]
    loc_hit, take = np.unique(j[hit], return_index=True)                     # first sample per location
    pos = np.searchsorted(locs, ploc[ip])
    for key in MULTIPLIER_FIELDS[dim]:
        v = np.zeros(len(locs))
        v[loc_hit] = samples[key][order][hit[take]]
        pd[key][ip] = v[pos]
