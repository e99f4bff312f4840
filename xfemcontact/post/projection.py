"""The floor of the multiplier space: L2 projections of reference multipliers.

The computed LAGS_C and LAGS_F1 are Galerkin multipliers: at best they are about
the L2 projection, on the interface, of the exact pressure and friction traction
onto the trace of the multiplier space.  Projecting a case's ``[reference]``
formulas and comparing them at the interface points (code_aster's NFISSU points)
gives the error the space itself cannot go below, to set the computed errors
against (``bench/multiplier_limit.py``).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from xfemcontact._petsc import PETSc

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.case.formula import Formula
    from xfemcontact.model import Model

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]


def _gathered_system(model: Model, values: list[FloatArray], phi: FloatArray | None = None,
                     dof: IntArray | None = None) -> tuple[IntArray, Any, list[NDArray[Any]]]:
    """Mass matrix of the carriers' traces and right-hand sides of ``values`` (list of
    (k, ng) arrays at the interface Gauss points), summed over every process.  ``phi (k,
    ng, m)``, ``dof (k, m)``: the functions at the points and their global ids (-1: none);
    by default the run's multiplier space (the global LAGS_C indices of its carriers)."""
    problem = model.problem
    # a contact problem (multipliers): it has phi and rep_index
    assert problem is not None and problem.phi is not None and problem.rep_index is not None
    w = problem.points.w                                         # (k, ng)
    phi = problem.phi if phi is None else phi                    # (k, ng, m)
    dof = problem.rep_index if dof is None else dof              # (k, m)
    M = np.einsum("kq,kqa,kqb->kab", w, phi, phi)
    rows = np.broadcast_to(dof[:, :, None], M.shape)
    cols = np.broadcast_to(dof[:, None, :], M.shape)
    ok = (rows >= 0) & (cols >= 0)
    rhs = [np.einsum("kq,kqa->ka", w * v, phi) for v in values]
    live = dof >= 0
    parts = model.comm.tompi4py().allgather((rows[ok], cols[ok], M[ok], dof[live],
                                             [b[live] for b in rhs]))
    r = np.concatenate([p[0] for p in parts])
    c = np.concatenate([p[1] for p in parts])
    ids, inv = np.unique(np.r_[r, c], return_inverse=True)
    n = len(ids)
    A = sp.coo_matrix((np.concatenate([p[2] for p in parts]), (inv[: len(r)], inv[len(r):])),
                      shape=(n, n)).tocsc()
    at = np.searchsorted(ids, np.concatenate([p[3] for p in parts]))
    B = [np.bincount(at, weights=np.concatenate([p[4][i] for p in parts]), minlength=n)
         for i in range(len(values))]
    return ids, A, B


def best_errors(model: Model, lags_c: Formula, lags_f1: Formula) -> dict[str, float]:
    """Largest errors at the interface points of the L2-best LAGS_C and LAGS_F1.

    ``lags_c``, ``lags_f1``: reference formulas ``f(x=..., y=...)`` (Pa and -).  The
    friction unknown is projected as the model solves for it: the tangential
    traction ``mu LAGS_C LAGS_F1`` (Pa) when it is the traction, else LAGS_F1.  The
    projections are put in a solution vector and read at the interface points by
    :meth:`InterfaceProblem.point_values`, like the computed ones.  Returns
    ``{"LAGS_C": e_c, "LAGS_F1": e_f}`` over every process.
    """
    from mpi4py import MPI      # initialised by PETSc by now (see _petsc: PML choice first)

    problem = model.problem
    assert problem is not None            # a contact problem (see _gathered_system)
    xg = problem.points.x
    c = lags_c(x=xg[..., 0], y=xg[..., 1])
    f = lags_f1(x=xg[..., 0], y=xg[..., 1])
    traction = problem.friction_unknown == "traction"
    ids, A, (bc, bf) = _gathered_system(model, [c, problem.mu * c * f if traction else f])
    solve = spl.factorized(A)
    x = model.layout.create_global_vec()
    x.set(0.0)
    lo, hi = x.getOwnershipRange()
    own = (ids >= lo) & (ids < hi)          # LAGS_C dof ids; LAGS_F1 is the next dof
    x.setValues(np.r_[ids[own], ids[own] + 1].astype(PETSc.IntType),
                np.r_[solve(bc)[own], solve(bf)[own]])
    x.assemble()
    v = problem.point_values(x, thresholds_from_x=True)
    mpi = model.comm.tompi4py()
    return {name: mpi.allreduce(float(np.abs(v[name] - ref(x=v["x"], y=v["y"])).max(initial=0.0)),
                                op=MPI.MAX)
            for name, ref in (("LAGS_C", lags_c), ("LAGS_F1", lags_f1))}


def best_approximation(model: Model, values: FloatArray, raw: bool = False) -> FloatArray:
    """The L2 projection of a field given at the interface Gauss points ``values (k, ng)``
    (this process's, as ``model.problem.points``) onto the trace of the multiplier space,
    at the same points ``(k, ng)``: the run's space (weak vertices extrapolated, merges), or
    with ``raw`` the raw vertex space (the vertex functions of every interface cell, each
    vertex a dof; vertices whose trace is zero are left out).  Both dimensions; collective."""
    problem = model.problem
    assert problem is not None and problem.space is not None      # a law with multipliers
    assert problem.phi is not None and problem.rep_index is not None
    phi, dof = problem.phi, problem.rep_index
    if raw:
        phi = model.mesh.element.shape_linear(problem.points.xi)     # (k, ng, nv)
        dof = problem.space.topo.verts                              # input ids of the vertices
    ids, A, (b,) = _gathered_system(model, [values], phi, dof)
    d = A.diagonal()
    live = d > 1e-14 * (d.max() if len(d) else 1.0)
    coef = np.zeros(len(ids) + 1)                                   # the last: padding slots
    if live.any():
        coef[:-1][live] = spl.spsolve(A[live][:, live].tocsc(), b[live])
    at = np.where(dof >= 0, np.searchsorted(ids, np.maximum(dof, 0)), len(ids))
    return np.einsum("kqa,ka->kq", phi, coef[at])


def l2_norm(model: Model, values: FloatArray) -> float:
    """sqrt(int v^2 dA / int dA) of ``values (k, ng)`` at the interface Gauss points (the
    points' weights; every process)."""
    from mpi4py import MPI

    w = model.problem.points.w if model.problem is not None else np.zeros((0, 1))
    mpi = model.comm.tompi4py()
    num = mpi.allreduce(float((w * values ** 2).sum()), op=MPI.SUM)
    den = mpi.allreduce(float(w.sum()), op=MPI.SUM)
    return float(np.sqrt(num / den)) if den > 0 else 0.0
