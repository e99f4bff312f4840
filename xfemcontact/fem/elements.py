"""Reference elements: QUAD8 (serendipity), TRIA6, HEXA20 (serendipity), TETRA10,
SEG3 and their linear companions, in one table (:func:`element`).

Node order (code_aster's, the MED file's): vertices, then the mid-edge nodes in
the order of :attr:`Element.edges`.

* 2-D: vertices counter-clockwise, edge ``k`` joining vertex ``k`` and ``k+1``;
  QUAD8 on [-1, 1]^2, TRIA6 on the triangle (0,0)-(1,0)-(0,1).
* 3-D: the right-hand rule on the vertices of every face of :attr:`Element.faces`
  gives its outward normal (MED's convention; VTK's, meshio's and Gmsh's cells
  are the mirror images, :attr:`Element.reverse`).  HEXA20 on [-1, 1]^3: vertices
  1-4 one face, 5-8 the opposite one (vertex 5 over vertex 1), mid-edge nodes of
  the edges 1-2, 2-3, 3-4, 4-1, then 5-6, 6-7, 7-8, 8-5, then 1-5, 2-6, 3-7, 4-8.
  TETRA10 on the tetrahedron (0,0,0)-(0,1,0)-(1,0,0)-(0,0,1): mid-edge nodes of
  1-2, 2-3, 3-1, 1-4, 2-4, 3-4.
* SEG3 on [-1, 1] with nodes at -1, +1, 0.

All evaluations are vectorised: ``xi`` has shape ``(..., dim)`` and the results
have shape ``(..., nn)`` for values and ``(..., nn, dim)`` for reference gradients.
The same kernels (Jacobians, inverse maps, physical gradients) serve every element.
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
    """A reference element (abstract: :class:`Tria6`, :class:`Quad8`, :class:`Tetra10`,
    :class:`Hexa20`)."""

    name: str
    dim: int = 2
    nv: int
    nn: int
    ref_nodes: FloatArray   # (nn, dim) reference coordinates of the nodes
    edges: IntArray         # (ne, 3) local nodes (a, b, mid) of each edge
    reverse: IntArray       # node permutation turning an inverted cell into a direct one
    ref_area_inv: float     # 1 / measure (area, volume) of the reference domain
    #: vertex quadruples (a, b, c, d) of the quadrangular faces: the cell is affine
    #: only if a + c = b + d on each (parallelograms)
    parallelograms: IntArray = np.zeros((0, 4), np.int64)
    #: 3-D: local nodes of each face in its own element's order (outward normal)
    faces: IntArray = np.zeros((0, 0), np.int64)
    face_type: str = ""     # 3-D: the element of the faces ("QUAD8", "TRIA6")
    #: polynomial degree of the products of reference gradients (the rule that
    #: integrates an affine cell's stiffness exactly)
    stiffness_degree: int = 2

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
        """Jacobians ``dx/dxi`` of cells ``x (ne, nn, dim)`` at ``xi (nq, dim)``: ``(ne, nq, dim, dim)``."""
        # one BLAS product over the node index: (ne, dim, nq, dim) -> (ne, nq, dim, dim)
        return np.tensordot(x, self.dshape(xi), axes=([1], [1])).transpose(0, 2, 1, 3)

    def jacobian_dets(self, x: FloatArray, xi: FloatArray) -> FloatArray:
        """Determinants ``(ne, nq)`` of the Jacobians of cells ``x`` at ``xi``."""
        return determinants(self.jacobians(x, xi))

    def linear_reference(self, xv: FloatArray, x: FloatArray, iters: int = 30,
                         tol: float = 1e-13) -> FloatArray:
        """Reference coordinates ``(k, dim)`` of points ``x (k, dim)`` (m) under the linear
        companion maps (TRIA3 / QUAD4 / TETRA4 / HEXA8) of cells with vertices ``xv (k, nv, dim)``.

        Newton on ``sum_a L_a(xi) xv_a = x``: one step for triangles, a few for
        quadrangles.  Points may lie outside the cell (extrapolation).
        """
        xi, _ = _pull_back(self.shape_linear, self.dshape_linear, xv, x[:, None], np.zeros(x[:, None].shape),
                           None, iters, tol)
        return xi[:, 0]

    def map_points(self, x: FloatArray, xi: FloatArray) -> FloatArray:
        """Physical points ``(k, ..., dim)`` (m) of reference points ``xi (k, ..., dim)``
        under the isoparametric maps of cells ``x (k, nn, dim)``."""
        return np.einsum("k...a,kai->k...i", self.shape(xi), x)

    def inverse_map(self, x: FloatArray, pts: FloatArray, xi0: ArrayLike,
                    live: ArrayLike | None = None, iters: int = 30,
                    tol: float = 1e-13) -> tuple[FloatArray, BoolArray]:
        """Reference coordinates ``(k, p, dim)`` of physical points ``pts (k, p, dim)`` in
        cells ``x (k, nn, dim)``: Newton on ``sum_a N_a(xi) x_a = pts`` from ``xi0``.

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
        """Whether reference points ``xi (..., dim)`` lie in the reference domain."""
        raise NotImplementedError


def _pull_back(shape: _Functions, dshape: _Functions, x: FloatArray, pts: FloatArray,
               xi0: ArrayLike, live: ArrayLike | None, iters: int,
               tol: float) -> tuple[FloatArray, BoolArray]:
    """Newton on ``sum_a shape_a(xi) x_a = pts`` for every point (see
    :meth:`Element.inverse_map`); ``shape``/``dshape`` give the map's functions."""
    k, p, dim = pts.shape
    xi = np.array(xi0, dtype=float).reshape(k * p, dim)
    target = pts.reshape(k * p, dim)
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
    return xi.reshape(k, p, dim), failed


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
    parallelograms = np.array([[0, 1, 2, 3]])
    stiffness_degree = 4

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


class Tetra10(Element):
    """Quadratic tetrahedron on (0,0,0)-(0,1,0)-(1,0,0)-(0,0,1) (code_aster's node order)."""

    name = "TETRA10"
    dim = 3
    nv, nn = 4, 10
    ref_nodes = np.array([[0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1],
                          [0, 0.5, 0], [0.5, 0.5, 0], [0.5, 0, 0],
                          [0, 0, 0.5], [0, 0.5, 0.5], [0.5, 0, 0.5]], float)
    edges = np.array([[0, 1, 4], [1, 2, 5], [2, 0, 6], [0, 3, 7], [1, 3, 8], [2, 3, 9]])
    reverse = np.array([0, 2, 1, 3, 6, 5, 4, 7, 9, 8])
    ref_area_inv = 6.0
    faces = np.array([[0, 1, 2, 4, 5, 6], [0, 3, 1, 7, 8, 4],
                      [1, 3, 2, 8, 9, 5], [2, 3, 0, 9, 7, 6]])
    face_type = "TRIA6"
    #: d(barycentric coordinate of vertex a)/d(xi): vertex 2 is (0,1,0), vertex 3 (1,0,0)
    _dbary = np.array([[-1.0, -1.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])

    @staticmethod
    def _bary(xi: FloatArray) -> FloatArray:
        """Barycentric coordinates ``(..., 4)`` of the vertices."""
        x, y, z = xi[..., 0], xi[..., 1], xi[..., 2]
        return np.stack([1.0 - x - y - z, y, x, z], axis=-1)

    def shape(self, xi: FloatArray) -> FloatArray:
        lam = self._bary(xi)
        e = self.edges
        return np.concatenate([lam * (2 * lam - 1), 4 * lam[..., e[:, 0]] * lam[..., e[:, 1]]], axis=-1)

    def dshape(self, xi: FloatArray) -> FloatArray:
        lam = self._bary(xi)[..., None]                     # (..., 4, 1)
        g = self._dbary                                     # (4, 3)
        e = self.edges
        vertex = (4 * lam - 1) * g
        edge = 4 * (lam[..., e[:, 0], :] * g[e[:, 1]] + lam[..., e[:, 1], :] * g[e[:, 0]])
        return np.concatenate([vertex, edge], axis=-2)

    def shape_linear(self, xi: FloatArray) -> FloatArray:
        return self._bary(xi)

    def dshape_linear(self, xi: FloatArray) -> FloatArray:
        return np.broadcast_to(self._dbary, xi.shape[:-1] + (4, 3))

    def quadrature(self, degree: int) -> tuple[FloatArray, FloatArray]:
        return quadrature.gauss_tetrahedron(degree)

    def contains(self, xi: FloatArray, tol: float = 1e-12) -> BoolArray:
        return np.all(xi >= -tol, axis=-1) & (xi.sum(-1) <= 1 + tol)


class Hexa20(Element):
    """Serendipity hexahedron on [-1, 1]^3 (code_aster's node order)."""

    name = "HEXA20"
    dim = 3
    nv, nn = 8, 20
    _vertices = np.array([[-1, -1, -1], [-1, 1, -1], [1, 1, -1], [1, -1, -1],
                          [-1, -1, 1], [-1, 1, 1], [1, 1, 1], [1, -1, 1]], float)
    edges = np.array([[0, 1, 8], [1, 2, 9], [2, 3, 10], [3, 0, 11],
                      [4, 5, 12], [5, 6, 13], [6, 7, 14], [7, 4, 15],
                      [0, 4, 16], [1, 5, 17], [2, 6, 18], [3, 7, 19]])
    ref_nodes = np.r_[_vertices, 0.5 * (_vertices[edges[:, 0]] + _vertices[edges[:, 1]])]
    reverse = np.array([0, 3, 2, 1, 4, 7, 6, 5, 11, 10, 9, 8, 15, 14, 13, 12, 16, 19, 18, 17])
    ref_area_inv = 0.125
    faces = np.array([[0, 1, 2, 3, 8, 9, 10, 11], [4, 7, 6, 5, 15, 14, 13, 12],
                      [0, 4, 5, 1, 16, 12, 17, 8], [1, 5, 6, 2, 17, 13, 18, 9],
                      [2, 6, 7, 3, 18, 14, 19, 10], [3, 7, 4, 0, 19, 15, 16, 11]])
    face_type = "QUAD8"
    parallelograms = faces[:, :4]
    stiffness_degree = 4

    def _factors(self, xi: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Per node and direction, the 1-D factor of the shape function and its
        derivative: ``1 + xi_k c_k`` (node coordinate c_k = +-1) or ``1 - xi_k^2``
        (c_k = 0); each ``(..., nn, 3)``."""
        c = self.ref_nodes
        x = xi[..., None, :]
        zero = c == 0
        f = np.where(zero, 1 - x * x, 1 + x * c)
        df = np.where(zero, -2 * x, c)
        return f, df

    def shape(self, xi: FloatArray) -> FloatArray:
        f, _ = self._factors(xi)
        prod = f.prod(axis=-1)
        nv = self.nv
        c = self.ref_nodes[:nv]
        corner = 0.125 * prod[..., :nv] * ((xi[..., None, :] * c).sum(-1) - 2)
        return np.concatenate([corner, 0.25 * prod[..., nv:]], axis=-1)

    def dshape(self, xi: FloatArray) -> FloatArray:
        f, df = self._factors(xi)
        nv = self.nv
        c = self.ref_nodes[:nv]
        # product of the factors of the other two directions, per direction k
        others = np.stack([f[..., 1] * f[..., 2], f[..., 0] * f[..., 2], f[..., 0] * f[..., 1]], axis=-1)
        s = (xi[..., None, :] * c).sum(-1, keepdims=True) - 2                     # (..., nv, 1)
        corner = 0.125 * others[..., :nv, :] * (df[..., :nv, :] * s + f[..., :nv, :] * c)
        mid = 0.25 * others[..., nv:, :] * df[..., nv:, :]
        return np.concatenate([corner, mid], axis=-2)

    def shape_linear(self, xi: FloatArray) -> FloatArray:
        c = self.ref_nodes[:self.nv]
        return 0.125 * (1 + xi[..., None, :] * c).prod(axis=-1)

    def dshape_linear(self, xi: FloatArray) -> FloatArray:
        c = self.ref_nodes[:self.nv]
        f = 1 + xi[..., None, :] * c                                              # (..., 8, 3)
        others = np.stack([f[..., 1] * f[..., 2], f[..., 0] * f[..., 2], f[..., 0] * f[..., 1]], axis=-1)
        return 0.125 * c * others

    def quadrature(self, degree: int) -> tuple[FloatArray, FloatArray]:
        return quadrature.gauss_cube(max(1, (degree + 2) // 2))

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


#: the reference elements by name
ELEMENTS: dict[str, type[Element]] = {"QUAD8": Quad8, "TRIA6": Tria6, "HEXA20": Hexa20, "TETRA10": Tetra10}


@lru_cache(maxsize=None)
def element(name: str) -> Element:
    """The reference element called ``name`` ("QUAD8", "TRIA6", "HEXA20" or "TETRA10")."""
    return ELEMENTS[name]()


#: a cell is affine when its mid-edge nodes and (quadrilaterals) its fourth vertex are
#: where an affine map puts them, to this fraction of its size
AFFINE_TOL = 1e-10


def affine_cells(el: Element, x: FloatArray) -> BoolArray:
    """Which cells ``x (ne, nn, dim)`` have an affine isoparametric map: ``(ne,)`` bool.

    Straight-edged simplices, parallelograms and parallelepipeds (every quadrangular
    face a parallelogram) with mid-edge nodes at the midpoints: their Jacobian is
    constant, so kernels can use one per cell.
    """
    e = el.edges
    mid = 0.5 * (x[:, e[:, 0]] + x[:, e[:, 1]])
    size = np.abs(x[:, 1] - x[:, 0]).max(axis=1) + np.abs(x[:, 2] - x[:, 0]).max(axis=1)
    err = np.abs(mid - x[:, e[:, 2]]).max(axis=(1, 2))
    for a, b, c, d in el.parallelograms:      # a + c == b + d
        err = np.maximum(err, np.abs(x[:, a] + x[:, c] - x[:, b] - x[:, d]).max(axis=1))
    return err <= AFFINE_TOL * size


def determinants(J: FloatArray) -> FloatArray:
    """Determinants ``(...)`` of 2 x 2 or 3 x 3 matrices ``J (..., d, d)``, written out."""
    if J.shape[-1] == 2:
        return J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    return (J[..., 0, 0] * (J[..., 1, 1] * J[..., 2, 2] - J[..., 1, 2] * J[..., 2, 1])
            - J[..., 0, 1] * (J[..., 1, 0] * J[..., 2, 2] - J[..., 1, 2] * J[..., 2, 0])
            + J[..., 0, 2] * (J[..., 1, 0] * J[..., 2, 1] - J[..., 1, 1] * J[..., 2, 0]))


def inverses(J: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(det (...), J^-1 (..., d, d))`` of 2 x 2 or 3 x 3 matrices, by cofactors."""
    det = determinants(J)
    if J.shape[-1] == 2:
        adj = np.stack([J[..., 1, 1], -J[..., 0, 1], -J[..., 1, 0], J[..., 0, 0]], axis=-1)
        return det, adj.reshape(J.shape) / det[..., None, None]
    i, j = (1, 2, 0), (2, 0, 1)
    # column c of J^-1 det: the cross product of rows c + 1 and c + 2 of J
    cols = [np.cross(J[..., i[c], :], J[..., j[c], :]) for c in range(3)]
    return det, np.stack(cols, axis=-1) / det[..., None, None]


def physical_gradients(dshape_ref: FloatArray, J: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Gradients ``dN/dx (..., nn, dim)`` from reference ones and Jacobians ``(..., dim, dim)``.

    Returns ``(dNdx, detJ)``.
    """
    if J.shape[-1] == 3:
        det, M = inverses(J)
        # dN/dx_j = sum_i dN/dxi_i dxi_i/dx_j
        return np.einsum("...ai,...ij->...aj", dshape_ref, M), det
    det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    r = 1.0 / det[..., None]
    a, b = J[..., 0, 0, None] * r, J[..., 0, 1, None] * r      # inverse, written out:
    c, d = J[..., 1, 0, None] * r, J[..., 1, 1, None] * r      # [[d, -b], [-c, a]]
    g0, g1 = dshape_ref[..., 0], dshape_ref[..., 1]
    # dN/dx_j = sum_i dN/dxi_i dxi_i/dx_j  (broadcast products beat batched 2x2 matmuls)
    return np.stack([g0 * d - g1 * c, g1 * a - g0 * b], axis=-1), det


def surface_geometry(el: Element, x: FloatArray, xi: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Points ``(k, nq, 3)``, area elements ``(k, nq)`` (m^2 per unit reference area) and
    unit normals ``(k, nq, 3)`` of the faces ``x (k, nn, 3)`` of 3-D cells, described by
    the 2-D element ``el`` (QUAD8, TRIA6), at its reference points ``xi (nq, 2)``.

    The surface Jacobian is the pair of tangents dx/dxi_1, dx/dxi_2; their cross
    product is the normal times the area element (outward for the faces of
    :attr:`Element.faces`).
    """
    N, dN = el.shape(xi), el.dshape(xi)                       # (nq, nn), (nq, nn, 2)
    pts = np.einsum("qa,kai->kqi", N, x)
    t = np.einsum("qaj,kai->kqij", dN, x)                     # (k, nq, 3, 2)
    n = np.cross(t[..., 0], t[..., 1])
    da = np.linalg.norm(n, axis=-1)
    return pts, da, n / da[..., None]
