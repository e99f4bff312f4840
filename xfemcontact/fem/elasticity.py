"""Linear isotropic elasticity in 2-D and 3-D: Hooke's law and batched element kernels.

Voigt order (code_aster's): (xx, yy, xy) in 2-D, (xx, yy, zz, xy, xz, yz) in 3-D,
with engineering shear strains gamma_ij = 2 eps_ij.  Stresses in Pa, strains
dimensionless, lengths in m.  The kernels read the dimension ``d`` from the
shapes of their arguments: one code for both.

Element kernels work on *generalised gradients* ``G (ne, nq, nf, d)``: the
physical gradients of the ``nf`` scalar functions of an element at its ``nq``
points, weighted elsewhere by ``w (ne, nq)`` (quadrature weight x Jacobian, m^d).
For a plain element the functions are the shape functions; for an enriched one
they are ``N_a`` followed by ``psi_a N_a`` (shifted Heaviside, constant per
integration cell), so one kernel serves both.  Element dofs are blocked by
component: function ``f``, component ``i`` is dof ``i * nf + f``.

Affine cells (straight-sided simplices, parallelograms, parallelepipeds) have
constant Jacobians; their stiffness is ``T_e @ R`` with ``R`` the reference gradient
products and ``T_e`` d^4 numbers per cell (:func:`affine_stiffness`), one BLAS
product per batch.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]

MODELS = ("C_PLAN", "D_PLAN", "3D")


def dimension(model: str) -> int:
    """Space dimension of a modelisation: 3 for "3D", 2 for the plane ones."""
    return 3 if model == "3D" else 2


def hooke(E: float, nu: float, model: str = "C_PLAN") -> FloatArray:
    """Voigt elasticity matrix: ``(3, 3)`` plane stress C_PLAN or plane strain D_PLAN,
    ``(6, 6)`` for 3D."""
    if model == "3D":
        lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
        mu = 0.5 * E / (1.0 + nu)
        D = np.zeros((6, 6))
        D[:3, :3] = lam
        D[np.arange(3), np.arange(3)] += 2.0 * mu
        D[np.arange(3, 6), np.arange(3, 6)] = mu
        return D
    if model == "C_PLAN":
        c = E / (1.0 - nu * nu)
        return c * np.array([[1.0, nu, 0.0], [nu, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - nu)]])
    if model == "D_PLAN":
        c = E / ((1.0 + nu) * (1.0 - 2.0 * nu))
        return c * np.array([[1.0 - nu, nu, 0.0], [nu, 1.0 - nu, 0.0], [0.0, 0.0, 0.5 - nu]])
    raise ValueError(f"unknown model {model!r} (expected one of {MODELS})")


#: per dimension, the (i, j) tensor index of each Voigt component
VOIGT_PAIRS = {2: ((0, 0), (1, 1), (0, 1)),
               3: ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))}
#: per dimension, tensor (i, j) -> Voigt index
_VOIGT = {2: np.array([[0, 2], [2, 1]]), 3: np.array([[0, 3, 4], [3, 1, 5], [4, 5, 2]])}


def voigt_dimension(n: int) -> int:
    """Space dimension of ``n`` Voigt components (3 -> 2, 6 -> 3)."""
    return {3: 2, 6: 3}[n]


def tensor(D: FloatArray) -> FloatArray:
    """Fourth-order tensor ``C[i, j, k, l] (d, d, d, d)`` from the Voigt matrix ``(3, 3)`` or ``(6, 6)``."""
    v = _VOIGT[voigt_dimension(len(D))]
    return D[v[:, :, None, None], v[None, None, :, :]]


def stiffness(G: FloatArray, w: FloatArray, C: FloatArray) -> FloatArray:
    """Element stiffness ``(ne, d nf, d nf)``: K[i f, j g] = sum_q w G_fk C_ikjl G_gl."""
    ne, nq, nf, d = G.shape
    Gc = [np.ascontiguousarray(G[..., k]) for k in range(d)]          # (ne, nq, nf)
    Gw = [(g * w[:, :, None]).transpose(0, 2, 1) for g in Gc]         # (ne, nf, nq)
    A = [[np.matmul(Gw[k], Gc[l]) for l in range(d)] for k in range(d)]
    K = np.zeros((ne, d, nf, d, nf))
    for i in range(d):
        for j in range(d):
            for k in range(d):
                for l in range(d):
                    if C[i, k, j, l] != 0.0:
                        K[:, i, :, j, :] += C[i, k, j, l] * A[k][l]
    return K.reshape(ne, d * nf, d * nf)


def reference_products(dshape_ref: FloatArray, wq: FloatArray) -> FloatArray:
    """``R (d^2, nf, nf)``: R[(a b)][f, g] = sum_q wq dN_f/dxi_a dN_g/dxi_b on the reference cell."""
    R = np.einsum("q,qfa,qgb->abfg", wq, dshape_ref, dshape_ref)
    return R.reshape(R.shape[0] * R.shape[1], *R.shape[2:])


def affine_basis(R: FloatArray, C: FloatArray) -> FloatArray:
    """``(d^4, (d nf)^2)`` matrix taking the products M_ak M_bl of an affine cell's
    inverse Jacobian M to its stiffness per unit det J (see :func:`affine_stiffness`)."""
    nf, d = R.shape[1], len(C)
    Rab = R.reshape(d, d, nf, nf)
    B = np.zeros((d, d, d, d, d, nf, d, nf))          # (a, k, b, l, i, f, j, g)
    for i in range(d):
        for j in range(d):
            B[:, :, :, :, i, :, j, :] = np.einsum("kl,abfg->akblfg", C[i, :, j, :], Rab)
    return B.reshape(d ** 4, (d * nf) ** 2)


def affine_stiffness(J: FloatArray, basis: FloatArray) -> FloatArray:
    """Stiffness ``(ne, d nf, d nf)`` of affine cells with Jacobians ``J (ne, d, d)``.

    With M = J^-1: K[i f, j g] = det J sum_{a k b l} C_ikjl M_ak M_bl R_ab[f, g],
    i.e. one product of the per-cell ``det J M (x) M`` with the constant ``basis``.
    Cells that all have the same J (a regular grid) get a read-only broadcast view.
    """
    n = int(round(np.sqrt(basis.shape[1])))
    if len(J) > 1 and (J == J[0]).all():     # a structured mesh: one product for all
        return np.broadcast_to(affine_stiffness(J[:1], basis), (len(J), n, n))
    det, M = inverse_jacobians(J)
    MM = (M[:, :, :, None, None] * M[:, None, None, :, :]) * det[:, None, None, None, None]
    return (MM.reshape(len(J), basis.shape[0]) @ basis).reshape(len(J), n, n)


def inverse_jacobians(J: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(det, M)`` of Jacobians ``J (ne, d, d)``: determinants ``(ne,)`` and inverses ``(ne, d, d)``."""
    if J.shape[-1] == 3:
        from xfemcontact.fem.elements import inverses

        return inverses(J)
    det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
    M = np.stack([J[:, 1, 1], -J[:, 0, 1], -J[:, 1, 0], J[:, 0, 0]], axis=1).reshape(-1, 2, 2) / det[:, None, None]
    return det, M


def _voigt(g: FloatArray) -> FloatArray:
    """Voigt strains ``(..., nv)`` (engineering shear) of displacement gradients ``g (..., d, d)``."""
    pairs = VOIGT_PAIRS[g.shape[-1]]
    return np.stack([g[..., i, i] if i == j else g[..., i, j] + g[..., j, i] for i, j in pairs], axis=-1)


def affine_strain(dshape_ref: FloatArray, M: FloatArray, ue: FloatArray) -> FloatArray:
    """Strains ``(ne, nq, nv)`` (Voigt) of affine cells with inverse Jacobians ``M (ne, d, d)``.

    ``dshape_ref (nq, nn, d)``: reference gradients at the points, the same for
    every cell; ``ue (ne, d nn)`` component-blocked dofs.  The reference
    gradient of u is one BLAS product for the batch; grad u = (du/dxi) M.
    """
    nq, nn, d = dshape_ref.shape
    ne = len(ue)
    gref = (ue.reshape(ne * d, nn) @ dshape_ref.transpose(1, 0, 2).reshape(nn, nq * d)).reshape(ne, d, nq, d)
    g = gref[..., 0, None] * M[:, None, None, 0, :]
    for a in range(1, d):
        g = g + gref[..., a, None] * M[:, None, None, a, :]
    return _voigt(g.transpose(0, 2, 1, 3))


def strain(G: FloatArray, ue: FloatArray) -> FloatArray:
    """Strains ``(ne, nq, nv)`` (Voigt) from element dofs ``ue (ne, d nf)``."""
    d = G.shape[-1]
    g = np.matmul(ue.reshape(len(ue), 1, d, -1), G)                  # (ne, nq, d, d) grad u
    return _voigt(g)


def internal_forces(G: FloatArray, w: FloatArray, sigma: FloatArray) -> FloatArray:
    """Element internal forces ``(ne, d nf)`` = sum_q w B^T sigma, sigma ``(ne, nq, nv)``."""
    s = sigma[..., _VOIGT[G.shape[-1]]]                      # (ne, nq, d, d) tensor
    f = np.einsum("eqfk,eqik,eq->eif", G, s, w, optimize=True)
    return f.reshape(len(G), f.shape[1] * f.shape[2])
