"""Linear isotropic elasticity in 2-D: Hooke's law and batched element kernels.

Voigt order (xx, yy, xy) with engineering shear strain gamma_xy = 2 eps_xy.
Stresses in Pa, strains dimensionless, lengths in m.

Element kernels work on *generalised gradients* ``G (ne, nq, nf, 2)``: the
physical gradients of the ``nf`` scalar functions of an element at its ``nq``
points, weighted elsewhere by ``w (ne, nq)`` (quadrature weight x Jacobian, m^2).
For a plain element the functions are the shape functions; for an enriched one
they are ``N_a`` followed by ``psi_a N_a`` (shifted Heaviside, constant per
integration cell), so one kernel serves both.  Element dofs are blocked by
component: function ``f``, component ``i`` is dof ``i * nf + f``.

Affine cells (straight-sided triangles, parallelograms) have constant Jacobians;
their stiffness is ``T_e @ R`` with ``R`` the reference gradient products and
``T_e`` 16 numbers per cell (:func:`affine_stiffness`), one BLAS product per batch.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]

MODELS = ("C_PLAN", "D_PLAN")


def hooke(E: float, nu: float, model: str = "C_PLAN") -> FloatArray:
    """Voigt elasticity matrix ``(3, 3)``: plane stress C_PLAN or plane strain D_PLAN."""
    if model == "C_PLAN":
        c = E / (1.0 - nu * nu)
        return c * np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - nu)]])
    if model == "D_PLAN":
        c = E / ((1.0 + nu) * (1.0 - 2.0 * nu))
        return c * np.array([[1.0 - nu, nu, 0.0], [nu, 1.0 - nu, 0.0], [0.0, 0.0, 0.5 - nu]])
    raise ValueError(f"unknown model {model!r} (expected one of {MODELS})")


_VOIGT = np.array([[0, 2], [2, 1]])   # tensor (i, j) -> Voigt index


def tensor(D: FloatArray) -> FloatArray:
    """Fourth-order tensor ``C[i, j, k, l] (2, 2, 2, 2)`` from the Voigt matrix."""
    return D[_VOIGT[:, :, None, None], _VOIGT[None, None, :, :]]


def stiffness(G: FloatArray, w: FloatArray, C: FloatArray) -> FloatArray:
    """Element stiffness ``(ne, 2 nf, 2 nf)``: K[i f, j g] = sum_q w G_fk C_ikjl G_gl."""
    ne, nq, nf, _ = G.shape
    Gc = [np.ascontiguousarray(G[..., k]) for k in range(2)]          # (ne, nq, nf)
    Gw = [(g * w[:, :, None]).transpose(0, 2, 1) for g in Gc]         # (ne, nf, nq)
    A = [[np.matmul(Gw[k], Gc[l]) for l in range(2)] for k in range(2)]
    K = np.zeros((ne, 2, nf, 2, nf))
    for i in range(2):
        for j in range(2):
            for k in range(2):
                for l in range(2):
                    if C[i, k, j, l] != 0.0:
                        K[:, i, :, j, :] += C[i, k, j, l] * A[k][l]
    return K.reshape(ne, 2 * nf, 2 * nf)


def reference_products(dshape_ref: FloatArray, wq: FloatArray) -> FloatArray:
    """``R (4, nf, nf)``: R[(a b)][f, g] = sum_q wq dN_f/dxi_a dN_g/dxi_b on the reference cell."""
    R = np.einsum("q,qfa,qgb->abfg", wq, dshape_ref, dshape_ref)
    return R.reshape(4, *R.shape[2:])


def affine_basis(R: FloatArray, C: FloatArray) -> FloatArray:
    """``(16, (2 nf)^2)`` matrix taking the products M_ak M_bl of an affine cell's
    inverse Jacobian M to its stiffness per unit det J (see :func:`affine_stiffness`)."""
    nf = R.shape[1]
    Rab = R.reshape(2, 2, nf, nf)
    B = np.zeros((2, 2, 2, 2, 2, nf, 2, nf))          # (a, k, b, l, i, f, j, g)
    for i in range(2):
        for j in range(2):
            B[:, :, :, :, i, :, j, :] = np.einsum("kl,abfg->akblfg", C[i, :, j, :], Rab)
    return B.reshape(16, (2 * nf) ** 2)


def affine_stiffness(J: FloatArray, basis: FloatArray) -> FloatArray:
    """Stiffness ``(ne, 2 nf, 2 nf)`` of affine cells with Jacobians ``J (ne, 2, 2)``.

    With M = J^-1: K[i f, j g] = det J sum_{a k b l} C_ikjl M_ak M_bl R_ab[f, g],
    i.e. one product of the per-cell ``det J M (x) M`` with the constant ``basis``.
    Cells that all have the same J (a regular grid) get a read-only broadcast view.
    """
    n = int(round(np.sqrt(basis.shape[1])))
    if len(J) > 1 and (J == J[0]).all():     # a structured mesh: one product for all
        return np.broadcast_to(affine_stiffness(J[:1], basis), (len(J), n, n))
    det, M = inverse_jacobians(J)
    MM = (M[:, :, :, None, None] * M[:, None, None, :, :]) * det[:, None, None, None, None]
    return (MM.reshape(len(J), 16) @ basis).reshape(len(J), n, n)


def inverse_jacobians(J: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(det, M)`` of Jacobians ``J (ne, 2, 2)``: determinants ``(ne,)`` and inverses ``(ne, 2, 2)``."""
    det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
    M = np.stack([J[:, 1, 1], -J[:, 0, 1], -J[:, 1, 0], J[:, 0, 0]], axis=1).reshape(-1, 2, 2) / det[:, None, None]
    return det, M


def affine_strain(dshape_ref: FloatArray, M: FloatArray, ue: FloatArray) -> FloatArray:
    """Strains ``(ne, nq, 3)`` (Voigt) of affine cells with inverse Jacobians ``M (ne, 2, 2)``.

    ``dshape_ref (nq, nn, 2)``: reference gradients at the points, the same for
    every cell; ``ue (ne, 2 nn)`` component-blocked dofs.  The reference
    gradient of u is one BLAS product for the batch; grad u = (du/dxi) M.
    """
    nq, nn, _ = dshape_ref.shape
    ne = len(ue)
    gref = (ue.reshape(ne * 2, nn) @ dshape_ref.transpose(1, 0, 2).reshape(nn, nq * 2)).reshape(ne, 2, nq, 2)
    g = gref[..., 0, None] * M[:, None, None, 0, :] + gref[..., 1, None] * M[:, None, None, 1, :]
    return np.stack([g[:, 0, :, 0], g[:, 1, :, 1], g[:, 0, :, 1] + g[:, 1, :, 0]], axis=-1)


def strain(G: FloatArray, ue: FloatArray) -> FloatArray:
    """Strains ``(ne, nq, 3)`` (Voigt) from element dofs ``ue (ne, 2 nf)``."""
    g = np.matmul(ue.reshape(len(ue), 1, 2, -1), G)                  # (ne, nq, 2, 2) grad u
    return np.stack([g[..., 0, 0], g[..., 1, 1], g[..., 0, 1] + g[..., 1, 0]], axis=-1)


def internal_forces(G: FloatArray, w: FloatArray, sigma: FloatArray) -> FloatArray:
    """Element internal forces ``(ne, 2 nf)`` = sum_q w B^T sigma, sigma ``(ne, nq, 3)``."""
    s = sigma[..., _VOIGT]                                   # (ne, nq, 2, 2) tensor
    f = np.einsum("eqfk,eqik,eq->eif", G, s, w, optimize=True)
    return f.reshape(len(G), f.shape[1] * f.shape[2])
