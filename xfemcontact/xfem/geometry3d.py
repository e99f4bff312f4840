"""The X-FEM geometry of a 3-D mesh (HEXA20, TETRA10) and its level set: readjusted
LN, cell sides, curved sub-tetrahedra of the cut cells and the interface facets.

The steps shared with 2-D are the 2-D code itself (:mod:`xfemcontact.xfem.levelset`,
dimension-free): LN at every node, mid-edge nodes included, scaled by a power of
two; the readjustment rules (round-off to 0, fit to a vertex when an edge's zero is
within 1e-6 of its length from it, one crossing per edge by moving mid-node values);
classification (``cut`` when a cell has strictly positive and strictly negative node
values, an error asking for a finer mesh when a cell of one sign holds the other sign
inside).  Unlike 2-D, an edge the interface crosses twice keeps its values (the thin cap
of the other side it cuts off is followed, not dropped: its cells are cut, and the
cutting splits their tetrahedra at the cap, :func:`xfemcontact.xfem.cut3d.split_double_crossings`).
The cutting is :mod:`xfemcontact.xfem.cut3d`.

A cell face with LN = 0 at all its nodes lies on the interface: its cells are not
cut, and the face (split into TRIA6 facets for a QUAD8 face) is an interface facet
owned by the cell on the - side, oriented from - to + like the others.  Faces on
the domain boundary are not interfaces.

This is a library layer: enrichment and contact in 3-D (issue 21, item 3) will
build on it.  ``volumes`` and ``interface_area`` are what its tests and the
convergence study measure.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from xfemcontact.errors import GeometryError
from xfemcontact.xfem import cut3d, integration3d, levelset
from xfemcontact.xfem.integration import cell_points

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.mesh.plex import LocalMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]


@dataclass
class Geometry3D:
    """The 3-D X-FEM geometry of the local mesh (see the module documentation)."""

    phi: FloatArray                      # (n,) LN at local nodes after readjustment
    readjustment: levelset.Readjustment
    cell_side: IntArray                  # (nc,) -1 / +1, 0 for cut cells
    subtets: cut3d.SubTets               # of the cut cells
    facets: cut3d.Facets                 # of the cut cells
    face_facets: cut3d.Facets            # cell faces lying on the interface
    off_surface: int = 0                 # interface edges whose mid-node stayed off LN = 0
    folded: int = 0                      # cut cells with a folded sub-tetrahedron

    @property
    def cut_cells(self) -> IntArray:
        return self.subtets.cells


def build(mesh: LocalMesh, phi: FloatArray) -> Geometry3D:
    """Readjust LN (node values ``phi (n,)``), classify and cut the cells of ``mesh``.

    Raises :class:`GeometryError` (one line, asking for a finer mesh) where the
    interface cannot be followed: a closed surface inside a cell, or a cut cell
    whose curved sub-cells fold or whose facet mid-nodes cannot be placed.
    """
    if mesh.dim != 3:
        raise ValueError("geometry3d is for 3-D meshes (xfemcontact.xfem.geometry for 2-D)")
    phi, info = levelset.readjust(mesh, phi, lift_double_crossings=False)
    cut = levelset.double_crossed_cells(mesh, phi) | cut3d.face_diagonal_dips(mesh.element, phi[mesh.cell_nodes])
    side = levelset.classify(mesh, phi, cut)
    cells = np.nonzero(side == 0)[0]
    subs, facets, bad, off = cut3d.cut_cells(mesh.element, phi[mesh.cell_nodes[cells]], cells,
                                             mesh.x[mesh.cell_nodes[cells]])
    if bad.any():
        c = cells[np.nonzero(bad)[0][0]]
        ctr = mesh.x[mesh.cell_nodes[c]].mean(axis=0)
        raise GeometryError(f"level set: the interface is too curved in cell {mesh.cell_ids[c]} near "
                            f"({ctr[0]:.6g}, {ctr[1]:.6g}, {ctr[2]:.6g}) to be followed by quadratic "
                            f"sub-cells: refine the mesh there")
    return Geometry3D(phi, info, side, subs, facets, face_facets(mesh, phi, side),
                      int(off.sum()), int(cut3d.folded(subs).sum()))


def face_facets(mesh: LocalMesh, phi: FloatArray, side: IntArray) -> cut3d.Facets:
    """Interface facets on cell faces with LN = 0 at all their nodes, owned by the cell
    on the - side; domain-boundary faces excluded (see the module documentation)."""
    el = mesh.element
    faces = el.faces
    on = np.all(phi[mesh.cell_nodes[:, faces]] == 0, axis=2) & (side == -1)[:, None]   # (nc, nfaces)
    cells, local = np.nonzero(on)
    if len(cells):
        bnd = boundary_face_keys(mesh)
        nvf = 4 if el.face_type == "QUAD8" else 3
        keys = np.sort(mesh.cell_nodes[cells[:, None], faces[local, :nvf]], axis=1)
        keep = ~_rows_in(keys, bnd)
        cells, local = cells[keep], local[keep]
    ref = el.ref_nodes
    f = faces[local]
    if el.face_type == "TRIA6":
        nodes = ref[f][:, None]                                                       # (k, 1, 6, 3)
    else:   # QUAD8 (a, b, c, d, ab, bc, cd, da): triangles (a, b, c) and (a, c, d), planar in xi
        X = ref[f]
        ac = 0.5 * (X[:, 0] + X[:, 2])
        nodes = np.stack([np.stack([X[:, 0], X[:, 1], X[:, 2], X[:, 4], X[:, 5], ac], axis=1),
                          np.stack([X[:, 0], X[:, 2], X[:, 3], ac, X[:, 6], X[:, 7]], axis=1)], axis=1)
    if len(cells) == 0:
        nodes = np.zeros((0, 1, 6, 3))
    # several faces of one cell: one row per face (the rows name their cell)
    return cut3d.Facets(cells, nodes, np.ones(nodes.shape[:2], bool))


def boundary_face_keys(mesh: LocalMesh) -> IntArray:
    """Sorted local vertex nodes ``(k, nvf)`` of the domain-boundary faces of the local mesh."""
    from xfemcontact.mesh import plex3d
    from xfemcontact.mesh.labels import _BOUNDARY

    dm = mesh.plex
    fs, fe = dm.getDepthStratum(2)
    pts = np.zeros(0, np.int64)
    if dm.hasLabel(_BOUNDARY) and dm.getStratumSize(_BOUNDARY, 1):
        pts = np.asarray(dm.getStratumIS(_BOUNDARY, 1).getIndices(), np.int64)
    faces = pts[(pts >= fs) & (pts < fe)]
    nvf = 4 if mesh.element.face_type == "QUAD8" else 3
    if len(faces) == 0:
        return np.zeros((0, nvf), np.int64)
    verts = plex3d._face_vertices(dm, faces, nvf)
    return np.sort(mesh.node_of_point[verts], axis=1)


def _rows_in(rows: IntArray, table: IntArray) -> BoolArray:
    from xfemcontact.mesh.plex3d import match_rows

    return match_rows(rows, table) >= 0


def volumes(mesh: LocalMesh, geo: Geometry3D, degree: int = 3) -> tuple[float, float]:
    """Volumes (m^3) of the - and + sides held by the local cells (``degree``: of the rule
    on the sub-tetrahedra, 3 is exact on affine parents)."""
    el = mesh.element
    out = np.zeros(2)
    whole = np.nonzero(geo.cell_side != 0)[0]
    if len(whole):
        pts = cell_points(el, mesh.x[mesh.cell_nodes[whole]], whole, geo.cell_side[whole], degree=2)
        out += [(pts.w * (pts.side < 0)).sum(), (pts.w * (pts.side > 0)).sum()]
    if len(geo.cut_cells):
        w, side = integration3d.subtet_weights(el, mesh.x[mesh.cell_nodes[geo.cut_cells]], geo.subtets, degree)
        out += [(w * (side < 0)).sum(), (w * (side > 0)).sum()]
    return float(out[0]), float(out[1])


def interface_points(mesh: LocalMesh, geo: Geometry3D, degree: int = 4) -> list[integration3d.FacetPoints]:
    """Gauss points of the interface: facets of cut cells, then interface faces."""
    el = mesh.element
    return [integration3d.facet_points(el, mesh.x[mesh.cell_nodes[f.cells]], geo.phi[mesh.cell_nodes[f.cells]],
                                       f, degree)
            for f in (geo.facets, geo.face_facets) if len(f)]


def interface_area(mesh: LocalMesh, geo: Geometry3D, degree: int = 4) -> float:
    """Area (m^2) of the interface held by the local cells."""
    return float(sum(p.w.sum() for p in interface_points(mesh, geo, degree)))
