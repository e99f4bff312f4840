"""Displacements, strains and stresses from a solution.

Nodal displacements are the standard dofs (with shifted Heaviside enrichment a
node's DX, DY are the displacement of its own side).  Stresses are evaluated at
quadrature points: plain cells with the standard rule, enriched cells on their
sub-cells with the Heaviside part of each side.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Iterator

import numpy as np

from xfemcontact.assembly import bulk
from xfemcontact.assembly.system import enriched_gradients
from xfemcontact.fem import elasticity
from xfemcontact.xfem import geometry as xgeo
from xfemcontact.xfem import integration

if TYPE_CHECKING:
    from numpy.typing import ArrayLike, NDArray

    from xfemcontact.dofs.layout import DofLayout
    from xfemcontact.fem.elements import Element
    from xfemcontact.mesh.plex import LocalMesh
    from xfemcontact.xfem.geometry import Geometry
    from xfemcontact.xfem.integration import CellPoints

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]


@dataclass
class PointValues:
    """Values at quadrature points of a set of cells."""

    cells: IntArray                 # (k,) local cell index of each row
    x: FloatArray                   # (k, nq, d)
    w: FloatArray                   # (k, nq) weights (0 on padding), m^d
    side: IntArray | FloatArray     # (k, nq) -1/+1 (interface) or 1
    stress: FloatArray              # (k, nq, nv) SIXX, SIYY, SIXY (3-D: SIXX, SIYY, SIZZ, SIXY, SIXZ, SIYZ), Pa
    strain: FloatArray              # (k, nq, nv) the same order, engineering shears


def nodal_displacement(layout: DofLayout, x_local: FloatArray) -> FloatArray:
    """``(n, d)`` DX, DY, [DZ] at the local nodes, m."""
    return x_local[layout.u_local]


def quadrature_stresses(mesh: LocalMesh, geo: Geometry | None, layout: DofLayout, D: FloatArray,
                        x_local: FloatArray) -> list[PointValues]:
    """Stresses at the quadrature points of every local cell, as a list of PointValues."""
    el = mesh.element
    out = []
    for cells, xc, ue, aff in _plain_chunks(mesh, geo, layout, x_local):
        for rows, kernel in ((np.nonzero(aff)[0], _affine_points), (np.nonzero(~aff)[0], _curved_points)):
            if len(rows):
                x, w, eps = kernel(el, xc[rows], ue[rows])
                out.append(PointValues(cells[rows], x, w, np.ones(w.shape), eps @ D.T, eps))
    for pts, eps in _enriched_strains(mesh, geo, layout, x_local):
        out.append(PointValues(pts.cells, pts.x, pts.w, pts.side, eps @ D.T, eps))
    return out


def cell_mean_strains(mesh: LocalMesh, geo: Geometry | None, layout: DofLayout,
                      x_local: FloatArray) -> FloatArray:
    """Area- (volume-) weighted mean strain ``(nc, nv)`` (Voigt, engineering shear) of
    every local cell.

    Affine uncut cells in closed form (the mean of the reference gradients times
    the cell's inverse Jacobian, one BLAS product per batch); other cells through
    their quadrature points, as :func:`quadrature_stresses` evaluates them.  The
    mean stress is ``eps @ D.T`` (linear elasticity).
    """
    el = mesh.element
    eps = np.zeros((len(mesh.cells), 3 * el.dim - 3))
    q, wq = el.quadrature(4)
    mean_dshape = np.einsum("q,qai->ai", wq, el.dshape(q))[None] / wq.sum()   # (1, nn, d)
    for cells, xc, ue, aff in _plain_chunks(mesh, geo, layout, x_local):
        if aff.any():
            _, M = elasticity.inverse_jacobians(el.jacobians(xc[aff], q[:1])[:, 0])
            eps[cells[aff]] = elasticity.affine_strain(mean_dshape, M, ue[aff])[:, 0]
        if (~aff).any():
            _, w, e = _curved_points(el, xc[~aff], ue[~aff])
            eps[cells[~aff]] = _weighted_mean(w, e)
    for pts, e in _enriched_strains(mesh, geo, layout, x_local):
        eps[pts.cells] = _weighted_mean(pts.w, e)
    return eps


def _plain_chunks(mesh: LocalMesh, geo: Geometry | None, layout: DofLayout,
                  x_local: FloatArray) -> Iterator[tuple[IntArray, FloatArray, FloatArray, BoolArray]]:
    """Uncut, unenriched cells by batches: ``(cells, xc (k, nn, d), ue (k, d nn), affine (k,))``."""
    plain = geo.plain_cells(mesh) if geo is not None else np.arange(len(mesh.cells))
    for s in range(0, len(plain), bulk.CHUNK):
        cells = plain[s:s + bulk.CHUNK]
        ue = x_local[bulk.plain_batch(mesh, layout, cells).local]
        yield cells, mesh.x[mesh.cell_nodes[cells]], ue, mesh.affine[cells]


def _enriched_strains(mesh: LocalMesh, geo: Geometry | None, layout: DofLayout,
                      x_local: FloatArray) -> Iterator[tuple[CellPoints, FloatArray]]:
    """Enriched cells by batches: ``(CellPoints, strains (k, nq, nv))``, Heaviside part included."""
    if geo is None:
        return
    for group in xgeo.cell_points(mesh, geo, geo.enriched_cells(mesh)):
        for pts in xgeo.chunks(group):
            ue = x_local[bulk.enriched_batch(mesh, layout, pts.cells).local]
            yield pts, elasticity.strain(enriched_gradients(mesh, geo, pts), ue)


def _weighted_mean(w: FloatArray, e: FloatArray) -> FloatArray:
    """Per cell, the mean of ``e (k, nq, nv)`` with weights ``w (k, nq)``."""
    return np.einsum("kq,kqi->ki", w, e) / w.sum(axis=1)[:, None]


def _affine_points(el: Element, xc: FloatArray, ue: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Points ``x (k, nq, d)``, weights ``(k, nq)`` and strains ``(k, nq, nv)`` of
    affine cells ``xc (k, nn, d)``: one Jacobian per cell, BLAS over the batch."""
    q, wq = el.quadrature(4)
    nq, nn, d = len(q), xc.shape[1], xc.shape[2]
    det, M = elasticity.inverse_jacobians(el.jacobians(xc, q[:1])[:, 0])
    x = (xc.transpose(0, 2, 1).reshape(-1, nn) @ el.shape(q).T).reshape(len(xc), d, nq).transpose(0, 2, 1)
    return x, wq[None] * det[:, None], elasticity.affine_strain(el.dshape(q), M, ue)


def _curved_points(el: Element, xc: FloatArray, ue: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """As :func:`_affine_points` for cells with a Jacobian that varies."""
    pts = integration.cell_points(el, xc, np.arange(len(xc)), np.ones(len(xc)))
    return pts.x, pts.w, elasticity.strain(pts.dNdx, ue)


def cell_node_displacement(model: Any, xl: FloatArray, cells: IntArray, side: ArrayLike) -> FloatArray:
    """Displacement ``(k, nn, d)`` (m) at the nodes of local ``cells (k,)`` on side
    ``side (k,)``: the shape functions are 1 at their own node, so ``u_a + psi_a h_a``.
    ``model``: a :class:`~xfemcontact.model.Model` (not imported: it imports this module)."""
    mesh, geo, layout = model.mesh, model.geo, model.layout
    nodes = mesh.cell_nodes[cells]
    u = xl[layout.u_local[nodes]]
    if geo is not None:
        hl = np.where(layout.h_local >= 0, layout.h_local, layout.dummy)
        psi = (np.asarray(side)[:, None] - geo.node_side[nodes]) * geo.enriched[nodes]
        u = u + psi[..., None] * xl[hl[nodes]]
    return u


def displacement_at(model: Any, xl: FloatArray, cells: IntArray, xi: FloatArray,
                    side: ArrayLike) -> FloatArray:
    """Displacement ``(k, p, d)`` (m) at parent reference points ``xi (k, p, d)`` of
    local ``cells (k,)``, on side ``side (k,)``:
    ``u = sum N_a a_a + sum psi_a N_a h_a``, ``psi_a = H(side) - H(node a)``."""
    mesh, geo, layout = model.mesh, model.geo, model.layout
    nodes = mesh.cell_nodes[cells]
    N = mesh.element.shape(xi)                                                # (k, p, nn)
    u = np.matmul(N, xl[layout.u_local[nodes]])
    if geo is not None:
        hl = np.where(layout.h_local >= 0, layout.h_local, layout.dummy)
        psi = (np.asarray(side)[:, None] - geo.node_side[nodes]) * geo.enriched[nodes]   # (k, nn)
        u += np.matmul(N * psi[:, None, :], xl[hl[nodes]])
    return u
