"""The mesh as read from a file or generated, before it goes into DMPlex.

A :class:`RawMesh` holds one cell type with our node order (code_aster's, see
:mod:`xfemcontact.fem.elements`): in 2-D QUAD8 or TRIA6, vertices counter-clockwise,
then the mid-edge nodes, edge ``k`` joining vertex ``k`` and vertex ``k+1``
(meshio's, MED's and Gmsh's order for these cells); in 3-D HEXA20 or TETRA10.
Groups keep their names: cell groups, face groups (3-D: QUAD8 faces of HEXA20
cells, TRIA6 faces of TETRA10 cells), edge groups (SEG3 boundary or interior edges)
and node groups.  It lives on rank 0 only.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from xfemcontact.errors import MeshError

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.fem.elements import Element

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]

#: number of vertices and of nodes of each supported cell type
CELL_TYPES = {"QUAD8": (4, 8), "TRIA6": (3, 6), "HEXA20": (8, 20), "TETRA10": (4, 10)}


@dataclass
class RawMesh:
    """A mesh of one quadratic cell type with its groups (see the module documentation)."""

    points: FloatArray                  # (n_nodes, dim) float, m
    cell_type: str                      # "QUAD8", "TRIA6", "HEXA20" or "TETRA10"
    cells: IntArray                     # (n_cells, nn) int node indices
    cell_groups: dict[str, IntArray] = field(default_factory=dict)    # name -> (k,) cell indices
    edge_groups: dict[str, IntArray] = field(default_factory=dict)    # name -> (k, 3) nodes (a, b, mid)
    node_groups: dict[str, IntArray] = field(default_factory=dict)    # name -> (k,) node indices
    source: str = "<generated>"         # file name used in messages
    point_data: dict[str, FloatArray] = field(default_factory=dict)   # name -> (n_nodes,) float nodal fields
    face_groups: dict[str, IntArray] = field(default_factory=dict)    # 3-D: name -> (k, 8|6) face nodes

    @property
    def n_vertices_per_cell(self) -> int:
        return CELL_TYPES[self.cell_type][0]

    @property
    def dim(self) -> int:
        """Space dimension of the cells (2 or 3)."""
        from xfemcontact.fem.elements import element

        return element(self.cell_type).dim

    @property
    def vertex_nodes(self) -> IntArray:
        """Sorted indices of the nodes that are cell vertices."""
        return np.unique(self.cells[:, : self.n_vertices_per_cell])

    def group_names(self) -> list[str]:
        return sorted(set(self.cell_groups) | set(self.face_groups) | set(self.edge_groups)
                      | set(self.node_groups))

    def group_nodes(self, name: str) -> IntArray:
        """All node indices of group ``name`` (nodes of its cells, faces or edges)."""
        parts = []
        if name in self.node_groups:
            parts.append(self.node_groups[name])
        if name in self.edge_groups:
            parts.append(self.edge_groups[name].ravel())
        if name in self.face_groups:
            parts.append(self.face_groups[name].ravel())
        if name in self.cell_groups:
            parts.append(self.cells[self.cell_groups[name]].ravel())
        if not parts:
            raise KeyError(name)
        return np.unique(np.concatenate(parts))

    def check(self) -> RawMesh:
        """Validate shapes and geometry; re-orient clockwise (2-D) or inverted (3-D) cells.

        Every cell is made direct: counter-clockwise in 2-D, a positive Jacobian at
        its centre in 3-D (a consistently mirrored mesh is legal input).  Cells whose
        isoparametric Jacobian vanishes or changes sign inside them (folded,
        degenerate or badly placed mid-nodes) raise :class:`MeshError` naming the
        first such cell.
        """
        if self.cell_type not in CELL_TYPES:
            raise MeshError(f"{self.source}: unsupported cell type {self.cell_type} "
                            f"(supported: {', '.join(CELL_TYPES)})")
        nv, nn = CELL_TYPES[self.cell_type]
        if self.cells.ndim != 2 or self.cells.shape[1] != nn or len(self.cells) == 0:
            raise MeshError(f"{self.source}: no {self.cell_type} cells")
        if self.cells.min() < 0 or self.cells.max() >= len(self.points):
            raise MeshError(f"{self.source}: cell connectivity refers to missing nodes")
        if not np.all(np.isfinite(self.points)):
            raise MeshError(f"{self.source}: node coordinates are not finite")
        from xfemcontact.fem.elements import element

        ref = element(self.cell_type)
        if self.points.ndim != 2 or self.points.shape[1] != ref.dim:
            raise MeshError(f"{self.source}: {self.cell_type} cells need {ref.dim}-D node coordinates "
                            f"(got shape {self.points.shape})")
        x = self.points[self.cells]                                  # (ne, nn, dim)
        area = _signed_measures(ref, x)          # area (2-D) or volume (3-D) decides the orientation
        flip = area < 0
        if flip.any():
            self.cells[flip] = self.cells[flip][:, ref.reverse]
            x = self.points[self.cells]
        bad = np.zeros(len(x), bool)
        step = 65536                              # bounded temporaries (3-D: 37 points a cell)
        for s in range(0, len(x), step):
            detj = ref.jacobian_dets(x[s:s + step], ref.check_points)            # (ne, nq)
            size = np.abs(area[s:s + step])[:, None]
            bad[s:s + step] = (~(detj > 1e-10 * size * ref.ref_area_inv)).any(axis=1)
        if bad.any():
            c = int(np.nonzero(bad)[0][0])
            raise MeshError(
                f"{self.source}: cell {c} ({self.cell_type}, nodes {self.cells[c].tolist()}) "
                f"is degenerate or inverted (Jacobian <= 0 inside it)")
        return self


def _signed_measures(ref: Element, x: FloatArray) -> FloatArray:
    """Signed measures ``(ne,)`` of cells ``x (ne, nn, dim)``: in 2-D the area of the
    vertex polygon (> 0 counter-clockwise), in 3-D the Jacobian determinant at the
    reference centre over ``ref_area_inv`` (> 0 for a direct cell), m^dim."""
    if ref.dim == 2:
        v = x[:, :ref.nv]
        return 0.5 * np.sum(v[:, :, 0] * np.roll(v[:, :, 1], -1, axis=1)
                            - np.roll(v[:, :, 0], -1, axis=1) * v[:, :, 1], axis=1)
    centre = ref.ref_nodes[:ref.nv].mean(axis=0)[None]
    return ref.jacobian_dets(x, centre)[:, 0] / ref.ref_area_inv
