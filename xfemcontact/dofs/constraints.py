"""Which components are imposed, and their values.

Imposed displacements (code_aster DDL_IMPO) fix DX/DY (DZ in 3-D) at the nodes of
their groups: the displacement of the node's own side (the Heaviside functions
are shifted).  At an enriched node the displacement must hold on both sides of
the interface wherever the interface reaches the constrained boundary, so its
Heaviside dofs of the same components are fixed to zero when an edge (3-D: a
face) of the group through the node touches the interface (or when the group is
a group of nodes).  A law with ``zero_jump`` (bonded) fixes every Heaviside dof.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Iterable

import numpy as np

from xfemcontact.mesh.plex import NODE, reduce_nodes

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.case.functions import TimeFormula
    from xfemcontact.case.load import Case
    from xfemcontact.contact.laws.base import InterfaceLaw
    from xfemcontact.mesh.plex import LocalMesh
    from xfemcontact.xfem.geometry import Geometry

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]


def _touching_edges(mesh: LocalMesh, phi: FloatArray, edges: IntArray) -> BoolArray:
    """Edges ``(k, 3)`` (or faces ``(k, m)``) along which LN is not of one strict sign."""
    p = phi[edges]
    return ~(np.all(p > 0, axis=1) | np.all(p < 0, axis=1))


def fixed_components(mesh: LocalMesh, case: Case, geo: Geometry | None, law: InterfaceLaw | None,
                     values_fn: Callable[[IntArray, TimeFormula], FloatArray]) -> tuple[BoolArray, FloatArray]:
    """Imposed components ``(n, 2 d)`` (DX, DY, [DZ], H1X, H1Y, [H1Z]) and displacement
    values ``(n, d)``, d the mesh's dimension.

    ``law``: the interface law (None without interface); ``values_fn(nodes,
    formula)`` evaluates a formula at nodes.
    """
    n, d = len(mesh.x), mesh.dim
    fixed = np.zeros((n, 2 * d), dtype=bool)
    values = np.zeros((n, d))
    for bc in case.dirichlet:
        nodes = group_nodes_everywhere(mesh, bc.groups)
        hnodes = _heaviside_nodes(mesh, geo, bc.groups) if geo is not None else np.zeros(0, int)
        for c, comp in enumerate(("DX", "DY", "DZ")[:d]):
            if comp in bc.components:
                fixed[nodes, c] = True
                values[nodes, c] = values_fn(nodes, bc.components[comp])
                fixed[hnodes, d + c] = True
    if geo is not None:
        fixed[:, d:] &= geo.enriched[:, None]
        if law is not None and law.zero_jump:
            fixed[:, d:] |= geo.enriched[:, None]
    return fixed, values


def group_nodes_everywhere(mesh: LocalMesh, groups: Iterable[str]) -> IntArray:
    """Local nodes of ``groups`` as every process holding them sees them.  A process can
    hold a node of a group without the face or edge that puts it there (a cell touching
    the boundary face by an edge only, in 3-D): the flags are combined over the
    processes, or a process would leave its copy of that node free."""
    flag = np.zeros(len(mesh.x), dtype=np.int64)
    for g in groups:
        flag[mesh.group_nodes(g)] = 1
    if mesh.comm.size > 1:
        flag = np.asarray(reduce_nodes(mesh, flag, "max"))
    return np.nonzero(flag)[0].astype(np.int64)


def _group_face_nodes(mesh: LocalMesh, group: str) -> IntArray:
    """``(k, m)`` nodes of every local face of 3-D group ``group`` (shared ones too; the
    nodes of each of the face's edges, so vertices come twice)."""
    from xfemcontact.mesh import plex3d

    edges = plex3d.face_edges(mesh.plex, mesh.group_points(group))           # (k, edges per face)
    if edges.size == 0:
        return np.zeros((0, 3), np.int64)
    return mesh.edge_nodes(edges.ravel()).reshape(len(edges), -1)


def _heaviside_nodes(mesh: LocalMesh, geo: Geometry, groups: Iterable[str]) -> IntArray:
    """Enriched nodes of ``groups`` where the interface reaches the group: the nodes of
    its edges (2-D) or faces (3-D) along which LN is not of one strict sign, and the
    nodes of node groups."""
    flag = np.zeros(len(mesh.x), dtype=np.int64)
    for g in groups:
        edges = mesh.group_edge_nodes(g)
        touch = _touching_edges(mesh, geo.phi, edges)
        flag[edges[touch].ravel()] = 1
        if mesh.dim == 3:
            faces = _group_face_nodes(mesh, g)
            flag[faces[_touching_edges(mesh, geo.phi, faces)].ravel()] = 1
        flag[mesh.node_of_point[mesh.group_points(g, NODE)]] = 1      # nodes of a node group
    flag = reduce_nodes(mesh, flag, "max").astype(bool)
    return np.nonzero(flag & geo.enriched)[0]
