"""The X-FEM geometry of a mesh and level set: cut cells, sides, enriched nodes.

Enrichment rule: node ``j`` carries Heaviside dofs when some cell of its support
has a part on the side opposite to the node (the node's side is H(x_j) = +1 when
LN(x_j) >= 0, -1 otherwise, so a node on the interface counts as +).  Its
function is ``psi_j N_j`` with the shifted Heaviside ``psi_j = H - H(x_j)``,
zero on the node's side, so nodal values stay the displacement of the node's
side.

Conditioning rule: when the interface passes very close to node ``j``, the part
of its support on the opposite side is tiny and its Heaviside dof is nearly
empty.  We measure it by the ratio of the stiffness-like diagonal terms

    r_j = int_{opposite side} |grad N_j|^2  /  int_{support} |grad N_j|^2

(the ratio of the H1X diagonal term to the DX one for an isotropic material)
and drop the Heaviside dofs of nodes with ``r_j < DROP_RATIO``.  A dropped node
takes its function out of the enriched space, so a constant jump (a slip, an
opening) is no longer reproduced on the thin part of its support: the price is
an error of the order of the jump times (d / h)^2, d the distance from the
interface to the node's cell corner.  The ratio falls like (d / h)^4 for the
nodes of a cell whose corner the interface clips (measured at d = 1e-3 h: 5e-13
on TRIA6 above a row of vertices, 7e-12 on QUAD8 past one vertex; tests/test_xfem_bulk.py),
like d / h elsewhere (QUAD8 above a row of vertices: 1.2e-4),
and readjustment already sends the interface through the vertices of an edge it
runs along within 1e-6 h of them (through a lone vertex within 1e-9 h).  DROP_RATIO = 1e-16 keeps every node down to d of about 1e-4 h; with 1e-12
the TRIA6 nodes at d = 1e-3 h were dropped and a slip of 8e-4 m came out 2.5e-10
m off in the gap (bench/campaign.py, limit-D_t6s_a+00_vtx); keeping every node
(1e-26) left a slanted interface 1e-6 h from a QUAD8 vertex with a
Jacobi-scaled condition number of 2.5e15 (1e-16: at most 2.3e13 over the sweep of
tests/test_xfem_bulk.py, MUMPS' own scaling copes with that).

One code for both dimensions: only the cutting differs.  In 2-D the cut cells
are cut by :mod:`xfemcontact.xfem.cut` into curved sub-triangles and interface
segments; in 3-D by :mod:`xfemcontact.xfem.geometry3d` (readjustment, then
:mod:`xfemcontact.xfem.cut3d`) into curved sub-tetrahedra and interface facets.
The sides, the enrichment and conditioning rules and the quadrature of cut
cells (:func:`cell_points`, a :class:`~xfemcontact.xfem.integration.CellPoints`
in both dimensions) read the dimension from the mesh.  In 3-D the 2-D segment
fields are empty and ``facets`` / ``face_facets`` hold the interface.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Iterator

import numpy as np

from xfemcontact.mesh.plex import reduce_nodes
from xfemcontact.xfem import cut, cut3d, geometry3d, integration, integration3d, levelset

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.mesh.plex import LocalMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]

DROP_RATIO = 1e-16


@dataclass
class Geometry:
    """The X-FEM geometry of the local mesh (see the module documentation)."""

    phi: FloatArray                     # (n,) LN at local nodes after readjustment
    readjustment: levelset.Readjustment
    cell_side: IntArray                 # (nc,) -1 / +1, 0 for cut cells
    node_side: IntArray                 # (n,) H(x_j): +1 if LN >= 0 else -1
    cut_segments: cut.Segments          # of cut cells
    edge_segments: cut.Segments         # lying on cell edges
    subcells: cut.SubCells | cut3d.SubTets    # of cut cells: sub-triangles (2-D), sub-tetrahedra (3-D)
    enriched: BoolArray                 # (n,) bool, carries H1X, H1Y, [H1Z]
    ratio: FloatArray                   # (n,) support ratio r_j (1 for non-enriched nodes)
    dropped: int                        # nodes whose Heaviside dofs the conditioning rule removed
    cut_points: list[integration.CellPoints] | None = field(default=None, repr=False)  # of cut cells, cached
    facets: cut3d.Facets | None = None        # 3-D: interface facets of cut cells
    face_facets: cut3d.Facets | None = None   # 3-D: cell faces lying on the interface
    off_surface: int = 0                # 3-D: interface edges whose mid-node stayed off LN = 0
    folded: int = 0                     # 3-D: cut cells with a folded sub-tetrahedron

    @property
    def cut_cells(self) -> IntArray:
        return self.subcells.cells

    def segments(self) -> cut.Segments:
        """All interface segments (cut cells first, then edge segments)."""
        a, b = self.cut_segments, self.edge_segments
        return cut.Segments(np.r_[a.cells, b.cells], np.concatenate([a.nodes, b.nodes]),
                            np.concatenate([a.where, b.where]))

    def interface_points(self, mesh: LocalMesh, degree: int = 4) -> list[integration3d.FacetPoints]:
        """3-D: Gauss points of the interface facets (cut cells, then cell faces on the
        interface), weights in m^2, normals from - to +; empty in 2-D."""
        el = mesh.element
        return [integration3d.facet_points(el, mesh.x[mesh.cell_nodes[f.cells]], self.phi[mesh.cell_nodes[f.cells]],
                                           f, degree)
                for f in (self.facets, self.face_facets) if f is not None and len(f)]

    def enriched_cells(self, mesh: LocalMesh) -> IntArray:
        """Cells where some enriched node's shifted Heaviside is not zero."""
        nodes = mesh.cell_nodes
        opp = self.enriched[nodes] & (self.node_side[nodes] != self.cell_side[:, None])
        return np.nonzero((self.cell_side == 0) | opp.any(axis=1))[0]

    def plain_cells(self, mesh: LocalMesh) -> IntArray:
        mask = np.ones(len(mesh.cells), dtype=bool)
        mask[self.enriched_cells(mesh)] = False
        return np.nonzero(mask)[0]


def build(mesh: LocalMesh, phi: FloatArray) -> Geometry:
    """Readjust LN, classify and cut the cells, select the enriched nodes (2-D and 3-D;
    only the cutting differs, see the module documentation)."""
    facets: tuple[cut3d.Facets | None, cut3d.Facets | None] = (None, None)
    subs: cut.SubCells | cut3d.SubTets
    quality = (0, 0)
    if mesh.dim == 3:
        g3 = geometry3d.build(mesh, phi)
        phi, info, side, subs = g3.phi, g3.readjustment, g3.cell_side, g3.subtets
        segs = esegs = _no_segments()
        facets = (g3.facets, g3.face_facets)
        quality = (g3.off_surface, g3.folded)
    else:
        phi, info, side, segs, subs = _cut(mesh, phi)
        esegs = cut.edge_segments(mesh, phi, side)
    node_side = np.where(phi >= 0, 1, -1)
    enriched = _opposite_in_support(mesh, side, node_side)
    geo = Geometry(phi, info, side, node_side, segs, esegs, subs, enriched,
                   np.ones(len(phi)), 0, None, *facets, *quality)
    ratio = support_ratio(mesh, geo)
    drop = enriched & (ratio < DROP_RATIO)
    geo.ratio = ratio
    geo.enriched = enriched & ~drop
    geo.dropped = int((drop & mesh.node_owned).sum())
    return geo


def _no_segments() -> cut.Segments:
    """No interface segments (3-D: the interface is made of facets)."""
    return cut.Segments(np.zeros(0, np.int64), np.zeros((0, 3, 2)), np.zeros((0, 2), np.int64))


def _cut(mesh: LocalMesh, phi_in: FloatArray) -> tuple[FloatArray, levelset.Readjustment, IntArray,
                                                       cut.Segments, cut.SubCells]:
    """Readjust, classify and cut.  Cut cells whose sub-cells cannot follow the
    interface along an edge it touches or nearly touches are cut again with the
    zero line pushed off their sagging edges (readjustment rule 3; collective)."""
    def attempt(push_off: BoolArray | None = None) -> tuple[
            FloatArray, levelset.Readjustment, IntArray, cut.Segments, cut.SubCells, BoolArray]:
        phi, info = levelset.readjust(mesh, phi_in, push_off)
        side = levelset.classify(mesh, phi)
        return (phi, info, side) + cut.cut_cells(mesh, phi, side)

    phi, info, side, segs, subs, bad = attempt()
    retry = np.zeros(len(phi), np.int64)
    retry[mesh.cell_nodes[segs.cells[bad], mesh.element.nv:].ravel()] = 1
    retry = reduce_nodes(mesh, retry, "max").astype(bool)
    if mesh.comm.tompi4py().allreduce(int(retry.any())):
        phi, info, side, segs, subs, bad = attempt(retry)
    if bad.any():
        raise cut.too_curved(mesh.cell_ids[segs.cells[np.nonzero(bad)[0][0]]])
    return phi, info, side, segs, subs


def _opposite_in_support(mesh: LocalMesh, side: IntArray, node_side: IntArray) -> BoolArray:
    """Nodes whose support has a part on the side opposite to them."""
    nodes = mesh.cell_nodes
    n = len(mesh.x)
    count = np.stack([np.bincount(nodes[side <= 0].ravel(), minlength=n),
                      np.bincount(nodes[side >= 0].ravel(), minlength=n)], axis=1)
    count = reduce_nodes(mesh, count, "sum")
    return np.where(node_side > 0, count[:, 0] > 0, count[:, 1] > 0)


def cell_points(mesh: LocalMesh, geo: Geometry, cells: IntArray) -> list[integration.CellPoints]:
    """Quadrature of ``cells``: sub-cells for cut ones, the standard rule otherwise.

    Returns a list of :class:`integration.CellPoints` (cut cells, by groups of one
    rule size -- in 3-D the cells with straight sub-tetrahedra, then those with curved
    ones, see :func:`_cut_points` --, then uncut cells).
    """
    el = mesh.element
    cut_mask = geo.cell_side[cells] == 0
    out = []
    cc = cells[cut_mask]
    if len(cc):
        for group in _cut_points(mesh, geo):
            mine = cc[np.isin(cc, group.cells)]
            if len(mine):
                out.append(group.take(np.searchsorted(group.cells, mine)))
    uc = cells[~cut_mask]
    if len(uc):
        out.append(integration.cell_points(el, mesh.x[mesh.cell_nodes[uc]], uc, geo.cell_side[uc]))
    return out


#: quadrature points of enriched cells handled at once by :func:`chunks`
POINTS_CHUNK = 1 << 16


def chunks(pts: integration.CellPoints, points: int = POINTS_CHUNK) -> Iterator[integration.CellPoints]:
    """``pts`` by batches of whole cells with at most ``points`` quadrature points (at least
    one cell): element matrices of cut 3-D cells (thousands of points each) then exist
    for one batch at a time.  ``pts`` itself when it fits."""
    per = max(1, points // max(1, pts.w.shape[1]))
    if len(pts.cells) <= per:
        yield pts
        return
    for s in range(0, len(pts.cells), per):
        yield pts.take(np.arange(s, min(s + per, len(pts.cells))))


def _cut_points(mesh: LocalMesh, geo: Geometry) -> list[integration.CellPoints]:
    """Sub-cell quadrature of all cut cells, computed once per geometry (assembly,
    support ratios and post-processing all integrate over the same sub-cells).

    2-D: one group.  3-D: the cells whose sub-tetrahedra are all straight (a planar cut
    of an affine parent) with the rule of ``integration3d.SUBTET_DEGREE``, then the
    others with ``integration3d.CURVED_SUBTET_DEGREE`` (the patch test on curved
    sub-cells); each group's cells in increasing order."""
    if geo.cut_points is None:
        sub = geo.subcells
        xc = mesh.x[mesh.cell_nodes[sub.cells]]
        if isinstance(sub, cut3d.SubTets):
            name = mesh.element.name
            curved = integration3d.curved_cells(sub)
            groups = []
            for rows, degree in ((~curved, integration3d.SUBTET_DEGREE[name]),
                                 (curved, integration3d.CURVED_SUBTET_DEGREE[name])):
                if rows.any():
                    groups.append(_subtet_points(mesh, xc[rows], cut3d.SubTets(sub.cells[rows], sub.nodes[rows],
                                                                                sub.side[rows]), degree))
            geo.cut_points = groups
        else:
            geo.cut_points = [integration.subcell_points(mesh.element, xc, sub, mesh.cell_ids[sub.cells])]
    return geo.cut_points


def _subtet_points(mesh: LocalMesh, xc: FloatArray, sub: cut3d.SubTets, degree: int) -> integration.CellPoints:
    """:func:`integration3d.subtet_points` computed by batches of cells of at most
    ``POINTS_CHUNK`` points into arrays allocated once (its temporaries are several
    times its result)."""
    k, ns = sub.side.shape
    per = max(1, POINTS_CHUNK // (ns * integration3d.rule_size(degree)))
    out: integration.CellPoints | None = None
    for s in range(0, k, per):
        part = integration3d.subtet_points(mesh.element, xc[s:s + per],
                                           cut3d.SubTets(sub.cells[s:s + per], sub.nodes[s:s + per],
                                                         sub.side[s:s + per]), degree)
        if per >= k:
            return part
        if out is None:
            out = integration.CellPoints(*(np.empty((k,) + getattr(part, f.name).shape[1:],
                                                    getattr(part, f.name).dtype)
                                           for f in fields(integration.CellPoints)))
        for f in fields(integration.CellPoints):
            getattr(out, f.name)[s:s + per] = getattr(part, f.name)
        del part
    assert out is not None                  # k > per >= 1: at least two batches
    return out


def support_ratio(mesh: LocalMesh, geo: Geometry) -> FloatArray:
    """r_j for every node (see the module docstring); 1 where not enriched."""
    n = len(mesh.x)
    cells = geo.enriched_cells(mesh)
    tot = np.zeros(n)
    opp = np.zeros(n)
    for group in cell_points(mesh, geo, cells):
        for pts in chunks(group):
            nodes = mesh.cell_nodes[pts.cells]                                   # (k, nn)
            grad2 = np.sum(pts.dNdx ** 2, axis=-1)                               # (k, nq, nn)
            g2 = np.einsum("kq,kqa->ka", pts.w, grad2)
            other = pts.side[:, :, None] != geo.node_side[nodes][:, None, :]    # (k, nq, nn)
            g2o = np.einsum("kq,kqa->ka", pts.w, grad2 * other)
            np.add.at(tot, nodes, g2)
            np.add.at(opp, nodes, g2o)
    # cells of the support outside the enriched set lie wholly on the node's side
    plain = geo.plain_cells(mesh)
    plain = plain[geo.enriched[mesh.cell_nodes[plain]].any(axis=1)]
    if len(plain):
        pts = integration.cell_points(mesh.element, mesh.x[mesh.cell_nodes[plain]], plain,
                                      geo.cell_side[plain])
        g2 = np.einsum("kq,kqa->ka", pts.w, np.sum(pts.dNdx ** 2, axis=-1))
        nodes = mesh.cell_nodes[plain]
        touched = geo.enriched[nodes]
        np.add.at(tot, nodes[touched], g2[touched])
    both = reduce_nodes(mesh, np.c_[tot, opp], "sum")
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(both[:, 0] > 0, both[:, 1] / both[:, 0], 1.0)
    return np.where(geo.enriched, ratio, 1.0)
