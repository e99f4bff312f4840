"""Reference elements: QUAD8 (serendipity), TRIA6, SEG3 and their linear companions.

Node order: vertices counter-clockwise, then mid-edge nodes, edge ``k`` joining
vertex ``k`` and ``k+1``.  Reference domains: QUAD8 on [-1, 1]^2, TRIA6 on the
triangle (0,0)-(1,0)-(0,1), SEG3 on [-1, 1] with nodes at -1, +1, 0.

All evaluations are vectorised: ``xi`` has shape ``(..., 2)`` and the results
have shape ``(..., nn)`` for values and ``(..., nn, 2)`` for reference gradients.
"""
from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING, Callable

import numpy as np

from xfemcontact.fem import quadrature

if TYPE_CHECKING:
    from numpy.typing import ArrayLike, NDArray

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]
    #: shape functions (or their gradients) at reference points
    _Functions = Callable[[FloatArray], FloatArray]


class Element:
    """A reference element (abstract: :class:`Tria6`, :class:`Quad8`)."""

    name: str
    nv: int
    nn: int
    ref_nodes: FloatArray   # (nn, 2) reference coordinates of the nodes
    edges: IntArray         # (ne, 3) local nodes (a, b, mid) of each edge
    reverse: IntArray       # node permutation turning a clockwise cell counter-clockwise
    ref_area_inv: float     # 1 / measure of the reference domain

    def shape(self, xi: FloatArray) -> FloatArray:
        raise NotImplementedError

    def dshape(self, xi: FloatArray) -> FloatArray:
        raise NotImplementedError

    def shape_linear(self, xi: FloatArray) -> FloatArray:
        """Values ``(..., nv)`` of the linear companion (TRIA3 / QUAD4) functions."""
        raise NotImplementedError

    def dshape_linear(self, xi: FloatArray) -> FloatArray:
        raise NotImplementedError

    def quadrature(self, degree: int) -> tuple[FloatArray, FloatArray]:
        raise NotImplementedError

    # -- geometry of physical cells ---------------------------------------
    def jacobians(self, x: FloatArray, xi: FloatArray) -> FloatArray:
        """Jacobians ``dx/dxi`` of cells ``x (ne, nn, 2)`` at ``xi (nq, 2)``: ``(ne, nq, 2, 2)``."""
        # one BLAS product over the node index: (ne, 2, nq, 2) -> (ne, nq, 2, 2)
        return np.tensordot(x, self.dshape(xi), axes=([1], [1])).transpose(0, 2, 1, 3)

    def jacobian_dets(self, x: FloatArray, xi: FloatArray) -> FloatArray:
        J = self.jacobians(x, xi)
        return J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]

    def linear_reference(self, xv: FloatArray, x: FloatArray, iters: int = 30,
                         tol: float = 1e-13) -> FloatArray:
        """Reference coordinates ``(k, 2)`` of points ``x (k, 2)`` (m) under the linear
        companion maps (TRIA3 / QUAD4) of cells with vertices ``xv (k, nv, 2)``.

        Newton on ``sum_a L_a(xi) xv_a = x``: one step for triangles, a few for
        quadrangles.  Points may lie outside the cell (extrapolation).
        """
        xi, _ = _pull_back(self.shape_linear, self.dshape_linear, xv, x[:, None], np.zeros(x[:, None].shape),
                           None, iters, tol)
        return xi[:, 0]

    def map_points(self, x: FloatArray, xi: FloatArray) -> FloatArray:
        """Physical points ``(k, ..., 2)`` (m) of reference points ``xi (k, ..., 2)``
        under the isoparametric maps of cells ``x (k, nn, 2)``."""
        return np.einsum("k...a,kai->k...i", self.shape(xi), x)

    def inverse_map(self, x: FloatArray, pts: FloatArray, xi0: ArrayLike,
                    live: ArrayLike | None = None, iters: int = 30,
                    tol: float = 1e-13) -> tuple[FloatArray, BoolArray]:
        """Reference coordinates ``(k, p, 2)`` of physical points ``pts (k, p, 2)`` in
        cells ``x (k, nn, 2)``: Newton on ``sum_a N_a(xi) x_a = pts`` from ``xi0``.

        ``live (k, p)`` bool limits the work to some points (the others keep
        ``xi0``).  A point stops when its Newton step is below ``tol`` (reference
        units) or its residual is at round-off of the coordinates, so points that
        ``xi0`` already maps, every point of an affine cell for a guess composed of
        affine maps, keep ``xi0`` exactly.
        Returns ``(xi, failed)``: ``failed (k,)`` marks cells with a point that did
        not converge.
        """
        return _pull_back(self.shape, self.dshape, x, pts, xi0, live, iters, tol)

    @property
    def check_points(self) -> FloatArray:
        """Points where a cell's Jacobian is checked: nodes and a Gauss rule."""
        q, _ = self.quadrature(4)
        return np.r_[self.ref_nodes, q]

    def contains(self, xi: FloatArray, tol: float = 1e-12) -> BoolArray:
        """Whether reference points ``xi (..., 2)`` lie in the reference domain."""
        raise NotImplementedError


def _pull_back(shape: _Functions, dshape: _Functions, x: FloatArray, pts: FloatArray,
               xi0: ArrayLike, live: ArrayLike | None, iters: int,
               tol: float) -> tuple[FloatArray, BoolArray]:
    """Newton on ``sum_a shape_a(xi) x_a = pts`` for every point (see
    :meth:`Element.inverse_map`); ``shape``/``dshape`` give the map's functions."""
    k, p = pts.shape[:2]
    xi = np.array(xi0, dtype=float).reshape(k * p, 2)
    target = pts.reshape(k * p, 2)
    cell = np.repeat(np.arange(k), p)
    active = np.ones(k * p, bool) if live is None else np.asarray(live, bool).reshape(-1).copy()
    floor = 16 * np.finfo(float).eps * np.abs(x).max(axis=(1, 2))         # (k,) round-off of x
    for _ in range(iters):
        idx = np.nonzero(active)[0]
        if len(idx) == 0:
            break
        xc = x[cell[idx]]
        r = np.einsum("ma,mai->mi", shape(xi[idx]), xc) - target[idx]
        J = np.einsum("mai,maj->mij", xc, dshape(xi[idx]))
        step = np.linalg.solve(J, r[..., None])[..., 0]
        small = (np.abs(step).max(axis=1) <= tol) | (np.abs(r).max(axis=1) <= floor[cell[idx]])
        xi[idx[~small]] -= step[~small]
        active[idx[small]] = False
    failed = np.zeros(k, bool)
    failed[cell[active]] = True
    return xi.reshape(k, p, 2), failed


class Tria6(Element):
    """Quadratic triangle on (0,0)-(1,0)-(0,1)."""

    name = "TRIA6"
    nv, nn = 3, 6
    ref_nodes = np.array([[0, 0], [1, 0], [0, 1], [0.5, 0], [0.5, 0.5], [0, 0.5]], float)
    edges = np.array([[0, 1, 3], [1, 2, 4], [2, 0, 5]])
    reverse = np.array([0, 2, 1, 5, 4, 3])
    ref_area_inv = 2.0

    @staticmethod
    def _bary(xi: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        x, y = xi[..., 0], xi[..., 1]
        return 1.0 - x - y, x, y

    def shape(self, xi: FloatArray) -> FloatArray:
        l0, l1, l2 = self._bary(xi)
        return np.stack([l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1),
                         4 * l0 * l1, 4 * l1 * l2, 4 * l2 * l0], axis=-1)

    def dshape(self, xi: FloatArray) -> FloatArray:
        l0, l1, l2 = self._bary(xi)
        # d(l0, l1, l2)/d(x, y) = (-1,-1), (1,0), (0,1)
        dx = np.stack([-(4 * l0 - 1), 4 * l1 - 1, 0 * l2,
                       4 * (l0 - l1), 4 * l2, -4 * l2], axis=-1)
        dy = np.stack([-(4 * l0 - 1), 0 * l1, 4 * l2 - 1,
                       -4 * l1, 4 * l1, 4 * (l0 - l2)], axis=-1)
        return np.stack([dx, dy], axis=-1)

    def shape_linear(self, xi: FloatArray) -> FloatArray:
        return np.stack(self._bary(xi), axis=-1)

    def dshape_linear(self, xi: FloatArray) -> FloatArray:
        g = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
        return np.broadcast_to(g, xi.shape[:-1] + (3, 2))

    def quadrature(self, degree: int) -> tuple[FloatArray, FloatArray]:
        return quadrature.gauss_triangle(degree)

    def contains(self, xi: FloatArray, tol: float = 1e-12) -> BoolArray:
        return (xi[..., 0] >= -tol) & (xi[..., 1] >= -tol) & (xi.sum(-1) <= 1 + tol)


class Quad8(Element):
    """Serendipity quadrangle on [-1, 1]^2."""

    name = "QUAD8"
    nv, nn = 4, 8
    ref_nodes = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1],
                          [0, -1], [1, 0], [0, 1], [-1, 0]], float)
    edges = np.array([[0, 1, 4], [1, 2, 5], [2, 3, 6], [3, 0, 7]])
    reverse = np.array([0, 3, 2, 1, 7, 6, 5, 4])
    ref_area_inv = 0.25

    def shape(self, xi: FloatArray) -> FloatArray:
        x, y = xi[..., 0, None], xi[..., 1, None]
        xc, yc = self.ref_nodes[:4, 0], self.ref_nodes[:4, 1]
        corner = 0.25 * (1 + x * xc) * (1 + y * yc) * (x * xc + y * yc - 1)
        mid_x = 0.5 * (1 - x * x) * (1 + y * np.array([-1.0, 1.0]))     # nodes 4, 6
        mid_y = 0.5 * (1 + x * np.array([1.0, -1.0])) * (1 - y * y)     # nodes 5, 7
        return np.concatenate([corner, mid_x[..., :1], mid_y[..., :1],
                               mid_x[..., 1:], mid_y[..., 1:]], axis=-1)

    def dshape(self, xi: FloatArray) -> FloatArray:
        x, y = xi[..., 0, None], xi[..., 1, None]
        xc, yc = self.ref_nodes[:4, 0], self.ref_nodes[:4, 1]
        cdx = 0.25 * xc * (1 + y * yc) * (2 * x * xc + y * yc)
        cdy = 0.25 * yc * (1 + x * xc) * (x * xc + 2 * y * yc)
        s = np.array([-1.0, 1.0])
        mxdx = -x * (1 + y * s)                  # d/dx of nodes 4, 6
        mxdy = 0.5 * (1 - x * x) * s
        t = np.array([1.0, -1.0])
        mydx = 0.5 * t * (1 - y * y)             # nodes 5, 7
        mydy = -(1 + x * t) * y
        dx = np.concatenate([cdx, mxdx[..., :1], mydx[..., :1], mxdx[..., 1:], mydx[..., 1:]], -1)
        dy = np.concatenate([cdy, mxdy[..., :1], mydy[..., :1], mxdy[..., 1:], mydy[..., 1:]], -1)
        return np.stack([dx, dy], axis=-1)

    def shape_linear(self, xi: FloatArray) -> FloatArray:
        x, y = xi[..., 0, None], xi[..., 1, None]
        xc, yc = self.ref_nodes[:4, 0], self.ref_nodes[:4, 1]
        return 0.25 * (1 + x * xc) * (1 + y * yc)

    def dshape_linear(self, xi: FloatArray) -> FloatArray:
        x, y = xi[..., 0, None], xi[..., 1, None]
        xc, yc = self.ref_nodes[:4, 0], self.ref_nodes[:4, 1]
        return np.stack([0.25 * xc * (1 + y * yc), 0.25 * yc * (1 + x * xc)], axis=-1)

    def quadrature(self, degree: int) -> tuple[FloatArray, FloatArray]:
        return quadrature.gauss_square(max(1, (degree + 2) // 2))

    def contains(self, xi: FloatArray, tol: float = 1e-12) -> BoolArray:
        return np.all(np.abs(xi) <= 1 + tol, axis=-1)


class Seg3:
    """Quadratic segment on [-1, 1], nodes at -1, +1, 0."""

    name = "SEG3"
    nn = 3

    @staticmethod
    def shape(s: ArrayLike) -> FloatArray:
        """Values ``(..., 3)`` at abscissae ``s (...)``."""
        s = np.asarray(s)[..., None]
        return np.concatenate([0.5 * s * (s - 1), 0.5 * s * (s + 1), 1 - s * s], axis=-1)

    @staticmethod
    def dshape(s: ArrayLike) -> FloatArray:
        """Derivatives ``(..., 3)`` at abscissae ``s (...)``."""
        s = np.asarray(s)[..., None]
        return np.concatenate([s - 0.5, s + 0.5, -2 * s], axis=-1)


@lru_cache(maxsize=None)
def element(name: str) -> Element:
    """The reference element called ``name`` ("QUAD8" or "TRIA6")."""
    return {"QUAD8": Quad8, "TRIA6": Tria6}[name]()


#: a cell is affine when its mid-edge nodes and (quadrilaterals) its fourth vertex are
#: where an affine map puts them, to this fraction of its size
AFFINE_TOL = 1e-10


def affine_cells(el: Element, x: FloatArray) -> BoolArray:
    """Which cells ``x (ne, nn, 2)`` have an affine isoparametric map: ``(ne,)`` bool.

    Straight-sided triangles and parallelograms with mid-edge nodes at the midpoints:
    their Jacobian is constant, so kernels can use one per cell.
    """
    e = el.edges
    mid = 0.5 * (x[:, e[:, 0]] + x[:, e[:, 1]])
    size = np.abs(x[:, 1] - x[:, 0]).max(axis=1) + np.abs(x[:, 2] - x[:, 0]).max(axis=1)
    err = np.abs(mid - x[:, e[:, 2]]).max(axis=(1, 2))
    if el.nv == 4:   # parallelogram: x0 + x2 == x1 + x3
        err = np.maximum(err, np.abs(x[:, 0] + x[:, 2] - x[:, 1] - x[:, 3]).max(axis=1))
    return err <= AFFINE_TOL * size


def physical_gradients(dshape_ref: FloatArray, J: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Gradients ``dN/dx (..., nn, 2)`` from reference ones and Jacobians ``(..., 2, 2)``.

    Returns ``(dNdx, detJ)``.
    """
    det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    r = 1.0 / det[..., None]
    a, b = J[..., 0, 0, None] * r, J[..., 0, 1, None] * r      # inverse, written out:
    c, d = J[..., 1, 0, None] * r, J[..., 1, 1, None] * r      # [[d, -b], [-c, a]]
    g0, g1 = dshape_ref[..., 0], dshape_ref[..., 1]
    # dN/dx_j = sum_i dN/dxi_i dxi_i/dx_j  (broadcast products beat batched 2x2 matmuls)
    return np.stack([g0 * d - g1 * c, g1 * a - g0 * b], axis=-1), det
