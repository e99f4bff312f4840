"""Quadrature on the sides of cut cells and on the interface segments.

Points are returned in the parent cell's reference coordinates ``xi`` (where the
parent's shape functions are evaluated) together with physical positions and
weights that include every Jacobian (m^2 for areas, m for lengths).
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

import numpy as np

from xfemcontact.fem.elements import Element, affine_cells, physical_gradients
from xfemcontact.fem.quadrature import gauss_segment, gauss_triangle
from xfemcontact.xfem.cut import TRI6, Segments, SubCells, not_invertible, segment_curve, subcell_jacobians

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]

#: polynomial degree of the rule on each sub-triangle: exact for the stiffness
#: of affine parents (TRIA6: 2 + 2 x 2, QUAD8 parallelograms: 4 + 2 x 2 ... + det)
SUBCELL_DEGREE = {"TRIA6": 6, "QUAD8": 8}


@dataclass
class CellPoints:
    """Quadrature points of a batch of cells, padded to ``nq`` per cell."""

    cells: IntArray      # (k,) local cell indices
    xi: FloatArray       # (k, nq, d) parent reference coordinates
    x: FloatArray        # (k, nq, d) physical coordinates, m
    w: FloatArray        # (k, nq) weights, m^d (0 on padding)
    side: IntArray | FloatArray     # (k, nq) -1 / +1 (0 on padding)
    dNdx: FloatArray     # (k, nq, nn, d) physical gradients of the parent's shape functions
    N: FloatArray        # (k, nq, nn) parent shape functions

    def take(self, rows: IntArray) -> CellPoints:
        """The points of the cells at positions ``rows``."""
        return CellPoints(*(getattr(self, f.name)[rows] for f in fields(self)))


def _parent_maps(el: Element, xc: FloatArray,
                 xi: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Physical points, gradients and det J of parents ``xc (k, nn, d)`` at ``xi``.

    ``xi``: ``(k, nq, d)`` per cell, or ``(nq, d)`` the same for every cell (the
    shape functions are then evaluated once).
    """
    if xi.ndim == 2:
        N0, dN0 = el.shape(xi), el.dshape(xi)                      # (nq, nn), (nq, nn, d)
        (nq, nn), k, d = N0.shape, len(xc), xc.shape[2]
        x = np.matmul(N0, xc)                                       # (k, nq, d)
        # J[k, q, i, j] = sum_a xc[k, a, i] dN0[q, a, j], as one BLAS product
        J = xc.transpose(0, 2, 1).reshape(-1, nn) @ dN0.transpose(1, 0, 2).reshape(nn, -1)
        J = J.reshape(k, d, nq, d).transpose(0, 2, 1, 3)
        dNdx, det = physical_gradients(dN0, J)
        return np.broadcast_to(N0, (k,) + N0.shape), x, dNdx, det
    N = el.shape(xi)
    dN = el.dshape(xi)
    x = np.matmul(N, xc)
    J = np.matmul(xc[:, None].swapaxes(-1, -2), dN)                 # (k, nq, 2, 2)
    dNdx, det = physical_gradients(dN, J)
    return N, x, dNdx, det


def subcell_points(el: Element, xc: FloatArray, sub: SubCells,
                   cell_ids: IntArray | None = None) -> CellPoints:
    """Quadrature of the sub-triangles ``sub`` (SubCells) of cells with coordinates ``xc``.

    Each sub-triangle is integrated as the physical 6-node triangle through the
    images of its nodes (see :mod:`cut`); its points are pulled back to the
    parent's ``xi`` for the shape functions.  On affine cells this is the
    reference sub-triangle mapped by the parent, point for point.  ``cell_ids (k,)``
    name the cells in errors.
    """
    zeta, wz = gauss_triangle(SUBCELL_DEGREE[el.name])
    k, ns = sub.side.shape
    nq = len(wz)
    X = el.map_points(xc, sub.nodes.reshape(k, ns * 6, 2)).reshape(k, ns, 6, 2)
    N6 = TRI6.shape(zeta)
    x = np.einsum("qa,ksai->ksqi", N6, X).reshape(k, ns * nq, 2)
    xi0 = np.einsum("qa,ksai->ksqi", N6, sub.nodes).reshape(k, ns * nq, 2)
    live = np.repeat(sub.side != 0, nq, axis=1)                               # (k, ns nq)
    # on affine cells the composed points xi0 are the pull-backs already
    xi, failed = el.inverse_map(xc, x, xi0, live & ~affine_cells(el, xc)[:, None])
    if failed.any():
        raise not_invertible(failed, cell_ids)
    xi[~live] = _centre(el)                                                   # padding: any point inside
    det_x = subcell_jacobians(X, zeta).reshape(k, ns * nq)                     # m^2 per reference area
    w = np.tile(wz, ns)[None, :] * det_x * live
    N, xp, dNdx, _ = _parent_maps(el, xc, xi)
    x = np.where(live[..., None], x, xp)
    side = np.repeat(sub.side, nq, axis=1)
    return CellPoints(sub.cells, xi, x, w, side, dNdx, N)


def _centre(el: Element) -> FloatArray:
    return el.ref_nodes[: el.nv].mean(axis=0)


def cell_points(el: Element, xc: FloatArray, cells: IntArray, side: IntArray | FloatArray,
                degree: int = 4) -> CellPoints:
    """Standard quadrature of whole (uncut) cells, all on side ``side (k,)``."""
    q, wq = el.quadrature(degree)
    N, x, dNdx, det = _parent_maps(el, xc, q)
    xi = np.broadcast_to(q, (len(cells),) + q.shape)
    return CellPoints(cells, xi, x, wq[None] * det, np.repeat(side[:, None], len(wq), axis=1), dNdx, N)


@dataclass
class SegmentPoints:
    """Gauss points of interface segments (one segment per owning cell)."""

    cells: IntArray      # (k,)
    xi: FloatArray       # (k, ng, 2) parent reference coordinates
    s: FloatArray        # (ng,) abscissae on the segment
    x: FloatArray        # (k, ng, 2) physical points, m
    w: FloatArray        # (k, ng) length weights, m
    normal: FloatArray   # (k, ng, 2) unit normal, from - to + (grad LN direction)
    tangent: FloatArray  # (k, ng, 2) unit tangent with non-negative x-component


def segment_points(el: Element, xc: FloatArray, seg: Segments, order: int,
                   cell_ids: IntArray | None = None) -> SegmentPoints:
    """Gauss-Legendre points (``order`` of them) on segments ``seg`` (cut.Segments),
    on the physical quadratic curve of each segment (:func:`cut.segment_curve`)."""
    s, ws = gauss_segment(order)
    s = s[:, 0]
    xi, x, dx = segment_curve(el, xc, seg.nodes, s, cell_ids)
    ds = np.linalg.norm(dx, axis=-1)
    n = np.stack([-dx[..., 1], dx[..., 0]], axis=-1) / ds[..., None]
    return SegmentPoints(seg.cells, xi, s, x, ws[None] * ds, n, tangent_of(n))


#: |n_y| below this is a vertical interface (normals computed from curved segments carry
#: round-off of a few 1e-14: with a tighter test the tangent of a vertical interface
#: flipped between +e_y and -e_y from one point to the next)
VERTICAL = 1e-10


def tangent_of(n: FloatArray) -> FloatArray:
    """code_aster's 2-D tangent: unit, non-negative x-component; e_y when n = +-e_x
    (to ``VERTICAL``)."""
    sgn = np.where(n[..., 1] >= 0, 1.0, -1.0)
    t = np.stack([sgn * n[..., 1], -sgn * n[..., 0]], axis=-1)
    vertical = np.abs(n[..., 1]) <= VERTICAL
    t[vertical] = [0.0, 1.0]
    return t
