"""The bulk system of one process: stiffness K and load vector.

``K`` holds the bulk stiffness (plain cells, and enriched cells integrated on
their sub-cells) with the sparsity of every coupling, interface ones included,
so the Jacobian built on it keeps one pattern for the whole run.  The load
vector is ``f0 = K_fc u_c - F_ext`` on the free dofs (lift of the imposed
displacements minus tractions and body forces): the bulk residual is
``K x + f0``.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Iterable

import numpy as np

from xfemcontact._petsc import PETSc
from xfemcontact.assembly import bulk, loads
from xfemcontact.fem import elasticity
from xfemcontact.fem.elements import Seg3
from xfemcontact.xfem import cut3d, integration3d
from xfemcontact.xfem import geometry as xgeo
from xfemcontact.xfem.levelset import edge_crossing

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.case.load import BodyForce, Traction
    from xfemcontact.dofs.layout import DofLayout
    from xfemcontact.mesh.plex import LocalMesh
    from xfemcontact.xfem.geometry import Geometry
    from xfemcontact.xfem.integration import CellPoints

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]


def bc_array(layout: DofLayout, fixed: BoolArray, values: FloatArray) -> FloatArray:
    """Local work array with the imposed values (DX, DY, [DZ]) at constrained dofs."""
    x = layout.local_array()
    for c in range(layout.dim):
        m = fixed[:, c]
        x[layout.u_local[m, c]] = values[m, c]
    return x


def heaviside_weights(mesh: LocalMesh, geo: Geometry, pts: CellPoints) -> FloatArray:
    """psi_a = H(x_q) - H(x_a) of every node of the cells of ``pts`` (0 if not enriched)."""
    nodes = mesh.cell_nodes[pts.cells]
    psi = pts.side[:, :, None] - geo.node_side[nodes][:, None, :]
    return psi * geo.enriched[nodes][:, None, :]


def enriched_gradients(mesh: LocalMesh, geo: Geometry, pts: CellPoints) -> FloatArray:
    """Gradients ``(k, nq, 2 nn, d)`` of the functions (N_a, psi_a N_a) of enriched cells
    at the points ``pts`` (see :func:`heaviside_weights`)."""
    return bulk.enriched_gradients(pts.dNdx, heaviside_weights(mesh, geo, pts))


def assemble_bulk(mesh: LocalMesh, geo: Geometry | None, layout: DofLayout, D: FloatArray, A: PETSc.Mat,
                  r_local: FloatArray, x_bc: FloatArray) -> None:
    """Bulk stiffness into ``A`` and Dirichlet lift into ``r_local``."""
    el = mesh.element
    plain = geo.plain_cells(mesh) if geo is not None else np.arange(len(mesh.cells))
    batch = bulk.plain_batch(mesh, layout, plain)
    bulk.assemble_plain(mesh, batch, bulk.PlainStiffness(el, D), A, r_local, x_bc)
    if geo is None:
        return
    C = elasticity.tensor(D)
    for group in xgeo.cell_points(mesh, geo, geo.enriched_cells(mesh)):
        for pts in xgeo.chunks(group):
            batch = bulk.enriched_batch(mesh, layout, pts.cells)
            K = elasticity.stiffness(enriched_gradients(mesh, geo, pts), pts.w, C)
            bulk.add_matrices(A, batch, K)
            bulk.add_lift(r_local, batch, K, x_bc)


def add_body_forces(mesh: LocalMesh, geo: Geometry | None, layout: DofLayout, body: BodyForce,
                    f_local: FloatArray) -> None:
    """Body forces (N/m^3) into the local array ``f_local``."""
    el = mesh.element
    plain = geo.plain_cells(mesh) if geo is not None else np.arange(len(mesh.cells))
    from xfemcontact.xfem import integration

    for s in range(0, len(plain), bulk.CHUNK):
        cells = plain[s:s + bulk.CHUNK]
        pts = integration.cell_points(el, mesh.x[mesh.cell_nodes[cells]], cells, np.ones(len(cells)))
        fe = loads.body_forces(pts.N, pts.w, pts.x, body)
        np.add.at(f_local, bulk.plain_batch(mesh, layout, cells).local, fe.reshape(len(cells), fe.shape[1] * fe.shape[2]))
    if geo is None:
        return
    for group in xgeo.cell_points(mesh, geo, geo.enriched_cells(mesh)):
        for pts in xgeo.chunks(group):
            psi = heaviside_weights(mesh, geo, pts)
            vals = np.concatenate([pts.N, psi * pts.N], axis=2)
            fe = loads.body_forces(vals, pts.w, pts.x, body)
            np.add.at(f_local, bulk.enriched_batch(mesh, layout, pts.cells).local,
                      fe.reshape(len(pts.cells), fe.shape[1] * fe.shape[2]))


def add_tractions(mesh: LocalMesh, geo: Geometry | None, layout: DofLayout, traction: Iterable[Traction],
                  f_local: FloatArray) -> None:
    """Surface tractions of the case into ``f_local``: on edges in 2-D, on faces in 3-D,
    each split by the interface (see :func:`_edge_forces_by_side`, :func:`add_face_tractions`)."""
    for spec in traction:
        if mesh.dim == 3:
            for g in spec.groups:
                add_face_tractions(mesh, geo, layout, mesh.group_faces(g), spec, f_local)
            continue
        for g in spec.groups:
            nodes, _, _ = mesh.group_edges(g)
            if len(nodes) == 0:
                continue
            xe = mesh.x[nodes]
            fe = _edge_forces_by_side(mesh, geo, nodes, xe, spec)        # (k, 2, 6)
            np.add.at(f_local, _edge_dofs(layout, nodes), fe.reshape(len(nodes), fe.shape[1] * fe.shape[2]))


def add_face_tractions(mesh: LocalMesh, geo: Geometry | None, layout: DofLayout,
                       faces: tuple[IntArray, IntArray, IntArray], spec: Traction,
                       f_local: FloatArray) -> None:
    """Forces of traction ``spec`` on the faces of a 3-D mesh into ``f_local``.

    ``faces``: ``(nodes (k, nf), cell (k,), local_face (k,))`` of
    :meth:`~xfemcontact.mesh.plex.LocalMesh.group_faces` (outward, in their
    element's order).  Faces of cells without Heaviside functions: the face's own
    element.  Faces of uncut cells with enriched nodes: the same forces, times
    ``psi_a = H(cell) - H(node a)`` on the Heaviside dofs.  Faces of cut cells: the
    faces of the cell's sub-tetrahedra lying on the face, each with the Heaviside
    value of its side (:func:`~xfemcontact.xfem.integration3d.cut_face_points`).
    """
    nodes, cell, local = faces
    if len(nodes) == 0:
        return
    if geo is None:
        fe = loads.face_forces(mesh.x[nodes], mesh.element.face_type, spec)    # (k, 3, nf)
        np.add.at(f_local, bulk._blocked(layout.u_local, nodes), fe.reshape(len(nodes), -1))
        return
    cut = geo.cell_side[cell] == 0
    whole, wcell = nodes[~cut], cell[~cut]
    if len(whole):
        fe = loads.face_forces(mesh.x[whole], mesh.element.face_type, spec)     # (k, 3, nf)
        psi = (geo.cell_side[wcell, None] - geo.node_side[whole]) * geo.enriched[whole]
        fe = np.concatenate([fe, fe * psi[:, None, :]], axis=2)                 # (k, 3, 2 nf)
        np.add.at(f_local, bulk.enriched_dofs(layout, whole), fe.reshape(len(fe), -1))
    if cut.any():
        sub = geo.subcells
        assert isinstance(sub, cut3d.SubTets)                                   # 3-D cut cells
        rows = np.searchsorted(sub.cells, cell[cut])
        sub = cut3d.SubTets(sub.cells[rows], sub.nodes[rows], sub.side[rows])
        pts, side = integration3d.cut_face_points(mesh.element, mesh.x[mesh.cell_nodes[sub.cells]], sub,
                                                  local[cut])
        t = loads.traction_vectors(spec, pts.x, pts.normal)                     # (k, p, 3)
        cn = mesh.cell_nodes[sub.cells]
        N = mesh.element.shape(pts.xi)                                          # (k, p, nn)
        psi = (side[:, :, None] - geo.node_side[cn][:, None, :]) * geo.enriched[cn][:, None, :]
        vals = np.concatenate([N, N * psi], axis=2)                             # (k, p, 2 nn)
        fc = np.einsum("kp,kpi,kpa->kia", pts.w, t, vals)
        np.add.at(f_local, bulk.enriched_dofs(layout, cn), fc.reshape(len(fc), -1))


def _edge_dofs(layout: DofLayout, nodes: IntArray) -> IntArray:
    return bulk.enriched_dofs(layout, nodes)


def _edge_forces_by_side(mesh: LocalMesh, geo: Geometry | None, nodes: IntArray, xe: FloatArray,
                         spec: Traction) -> FloatArray:
    """Forces on functions (N_a, psi_a N_a) of edge nodes: ``(k, 2, 6)``.

    An edge the interface crosses is split where its cell is cut (the same
    :func:`~xfemcontact.xfem.levelset.edge_crossing`), and each piece gets the
    Heaviside value of its side."""
    k = len(nodes)
    out = np.zeros((k, 2, 6))
    if geo is None:
        out[:, :, :3] = loads.edge_forces(xe, spec)
        return out
    phi = geo.phi[nodes]
    s_cut = edge_crossing(phi[:, 0], phi[:, 1], phi[:, 2])
    cut = np.where(np.isnan(s_cut), 1.0, s_cut)
    pieces: list[tuple[float | FloatArray, float | FloatArray]] = [(-1.0, cut), (cut, 1.0)]
    for start, stop in pieces:
        a = np.broadcast_to(start, (k,))
        b = np.broadcast_to(stop, (k,))
        live = b > a
        if not live.any():
            continue
        mid = Seg3.shape(0.5 * (a + b)[live])                          # side of the piece
        phim = np.einsum("ka,ka->k", mid, phi[live])
        H = np.where(phim >= 0, 1.0, -1.0)
        H = np.where(phim == 0, np.where(phi[live].max(axis=1) > 0, 1.0, -1.0), H)
        f = loads.edge_forces(xe[live], spec, (a[live], b[live]))      # (kl, 2, 3)
        psi = (H[:, None] - geo.node_side[nodes[live]]) * geo.enriched[nodes[live]]
        out[live, :, :3] += f
        out[live, :, 3:] += f * psi[:, None, :]
    return out


def local_to_global(layout: DofLayout, arr: FloatArray) -> PETSc.Vec:
    """Global Vec summing the local work array ``arr`` over processes (dummy dropped).

    On one process the global dofs are the free local dofs in order
    (``layout.identity``): a copy.  Otherwise the layout's scatter (free local dofs
    to their global entries, shared dofs summed on their owner).
    """
    g = layout.create_global_vec()
    if layout.identity:
        g.setArray(arr[layout.free_local])
        return g
    scatter, lv = layout.scatter
    lv.setArray(arr[:-1])
    g.set(0.0)
    scatter.scatter(lv, g, addv=PETSc.InsertMode.ADD_VALUES, mode=PETSc.ScatterMode.FORWARD)
    return g


def global_to_local(layout: DofLayout, g: PETSc.Vec, x_bc: FloatArray) -> FloatArray:
    """Local work array of global vector ``g`` with imposed values from ``x_bc``."""
    out = x_bc.copy()
    free = layout.free_local
    if layout.identity:
        out[free] = g.getArray(readonly=True)
        return out
    scatter, lv = layout.scatter
    scatter.scatter(g, lv, addv=PETSc.InsertMode.INSERT_VALUES, mode=PETSc.ScatterMode.REVERSE)
    out[free] = lv.getArray(readonly=True)[free]
    return out
