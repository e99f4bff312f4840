"""Quadrature rules on the reference segment, triangle, square, tetrahedron and cube.

Each function returns ``(points, weights)``: points ``(nq, dim)`` in reference
coordinates, weights ``(nq,)`` summing to the reference measure (2 for the
segment [-1, 1], 1/2 for the triangle (0,0)-(1,0)-(0,1), 4 for [-1, 1]^2, 1/6
for the tetrahedron (0,0,0)-(1,0,0)-(0,1,0)-(0,0,1), 8 for [-1, 1]^3).
"""
from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]
    #: ``(points (nq, dim), weights (nq,))`` of a rule
    Rule = tuple[FloatArray, FloatArray]
    #: points and weights of one orbit of a symmetric rule, as lists
    _Orbit = tuple[list[list[float]], list[float]]


@lru_cache(maxsize=None)
def gauss_segment(n: int) -> Rule:
    """n-point Gauss-Legendre rule on [-1, 1] (exact to degree 2n-1)."""
    x, w = np.polynomial.legendre.leggauss(n)
    return x[:, None], w


@lru_cache(maxsize=None)
def gauss_square(n: int) -> Rule:
    """n x n tensor Gauss rule on [-1, 1]^2."""
    x, w = np.polynomial.legendre.leggauss(n)
    X, Y = np.meshgrid(x, x, indexing="ij")
    return np.c_[X.ravel(), Y.ravel()], np.outer(w, w).ravel()


@lru_cache(maxsize=None)
def gauss_cube(n: int) -> Rule:
    """n x n x n tensor Gauss rule on [-1, 1]^3 (exact to degree 2n-1 in each variable)."""
    x, w = np.polynomial.legendre.leggauss(n)
    X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
    W = w[:, None, None] * w[None, :, None] * w[None, None, :]
    return np.c_[X.ravel(), Y.ravel(), Z.ravel()], W.ravel()


def _orbit3(a: float, w: float) -> _Orbit:
    b = 1.0 - 2.0 * a
    return [[a, a], [b, a], [a, b]], [w] * 3


def _orbit6(a: float, b: float, w: float) -> _Orbit:
    c = 1.0 - a - b
    return [[a, b], [b, a], [a, c], [c, a], [b, c], [c, b]], [w] * 6


def _rule(*orbits: _Orbit) -> Rule:
    pts: list[list[float]] = sum((o[0] for o in orbits), [])
    wts: list[float] = sum((o[1] for o in orbits), [])
    return np.array(pts), 0.5 * np.array(wts)


@lru_cache(maxsize=None)
def gauss_triangle(degree: int) -> Rule:
    """Symmetric rule exact to ``degree`` on the reference triangle.

    Degrees 1, 2, 4 and 6 use the classical 1-, 3-, 6- and 12-point rules
    (Strang-Fix / Dunavant); other degrees use a collapsed Gauss-Jacobi
    (Stroud conical product) rule, which is exact but not symmetric.
    """
    if degree <= 1:
        return np.array([[1.0 / 3.0, 1.0 / 3.0]]), np.array([0.5])
    if degree == 2:
        return _rule(_orbit3(1.0 / 6.0, 1.0 / 3.0))
    if degree <= 4:
        return _rule(_orbit3(0.445948490915965, 0.223381589678011),
                     _orbit3(0.091576213509771, 0.109951743655322))
    if degree <= 6:
        return _rule(_orbit3(0.249286745170910, 0.116786275726379),
                     _orbit3(0.063089014491502, 0.050844906370207),
                     _orbit6(0.053145049844817, 0.310352451033784, 0.082851075618374))
    return _stroud_triangle(degree)


def _stroud_triangle(degree: int) -> Rule:
    n = degree // 2 + 1
    # Gauss-Jacobi(alpha=1) in the collapsed direction absorbs the Duffy Jacobian
    from scipy.special import roots_jacobi

    s, ws = roots_jacobi(n, 1.0, 0.0)         # on [-1, 1], weight (1 - s)
    t, wt = np.polynomial.legendre.leggauss(n)
    s = 0.5 * (s + 1.0)                       # collapsed coordinate in [0, 1]
    ws = ws / 4.0                             # (1/2 for ds) * (1/2 for (1-s) scaling)
    t = 0.5 * (t + 1.0)
    wt = wt / 2.0
    S, T = np.meshgrid(s, t, indexing="ij")
    W = np.outer(ws, wt)
    x = S.ravel()
    y = ((1.0 - S) * T).ravel()
    return np.c_[x, y], W.ravel()


#: the symmetric 4-point rule of degree 2 on the tetrahedron: barycentric a, b, b, b
_TET4 = (0.5854101966249685, 0.1381966011250105)


@lru_cache(maxsize=None)
def gauss_tetrahedron(degree: int) -> Rule:
    """Rule exact to ``degree`` on the reference tetrahedron, positive weights.

    Degrees 1 and 2 use the centroid and the symmetric 4-point rule; higher
    degrees a collapsed (Stroud conical product) Gauss-Jacobi rule with
    ``(degree // 2 + 1)^3`` points, exact but not symmetric.
    """
    if degree <= 1:
        return np.full((1, 3), 0.25), np.array([1.0 / 6.0])
    if degree == 2:
        a, b = _TET4
        pts = np.full((4, 3), b)
        pts[np.arange(1, 4), np.arange(3)] = a          # vertex 0 at the origin: point 0 all b
        return pts, np.full(4, 1.0 / 24.0)
    return _stroud_tetrahedron(degree)


def _collapsed(n: int, alpha: float) -> Rule:
    """Gauss-Jacobi points in [0, 1] with weights for the weight ``(1 - s)^alpha``."""
    from scipy.special import roots_jacobi

    if alpha == 0:
        t, w = np.polynomial.legendre.leggauss(n)
    else:
        t, w = roots_jacobi(n, alpha, 0.0)
    return 0.5 * (t + 1.0), w / 2.0 ** (alpha + 1)


def _stroud_tetrahedron(degree: int) -> Rule:
    n = degree // 2 + 1
    r, wr = _collapsed(n, 2.0)        # x = r: weight (1 - r)^2 from the collapse
    s, ws = _collapsed(n, 1.0)        # y = (1 - r) s: weight (1 - s)
    t, wt = _collapsed(n, 0.0)        # z = (1 - r)(1 - s) t
    R, S, T = np.meshgrid(r, s, t, indexing="ij")
    W = wr[:, None, None] * ws[None, :, None] * wt[None, None, :]
    x = R
    y = (1.0 - R) * S
    z = (1.0 - R) * (1.0 - S) * T
    return np.c_[x.ravel(), y.ravel(), z.ravel()], W.ravel()
