"""Bulk elasticity: element stiffness of plain and enriched cells, assembled by batches.

A *batch* is a set of cells sharing a dof layout:

* plain cells: functions ``N_a`` of the cell's nodes, dofs ``(DX, DY, [DZ])``;
* enriched cells: functions ``N_a`` then ``psi_a N_a`` (shifted Heaviside,
  constant on each integration sub-cell), per component ``DX`` then ``H1X``
  (``DY``, ``H1Y``, [``DZ``, ``H1Z``]) -- absent Heaviside dofs point to a slot
  that is always zero.

Element dofs are blocked by component (see :mod:`xfemcontact.fem.elasticity`).
Work is chunked so that element matrices of at most ``CHUNK`` cells exist at once.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from xfemcontact.fem import elasticity
from xfemcontact.fem.elements import affine_cells, physical_gradients

if TYPE_CHECKING:
    from numpy.typing import NDArray
    from petsc4py import PETSc

    from xfemcontact.dofs.layout import DofLayout
    from xfemcontact.fem.elements import Element
    from xfemcontact.mesh.plex import LocalMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]

CHUNK = 16384


@dataclass
class Batch:
    """Cells assembled together: their local and global dof indices ``(ne, nd)``."""

    cells: IntArray       # (ne,) local cell indices
    local: IntArray       # (ne, nd) indices into a local array (absent -> layout.dummy)
    glob: IntArray        # (ne, nd) global rows/columns (-1: constrained or absent)

    def __len__(self) -> int:
        return len(self.cells)


def _blocked(arr: IntArray, nodes: IntArray) -> IntArray:
    """``(ne, d nn)`` component-blocked indices from per-node ``arr (n, d)``."""
    return np.concatenate([arr[nodes, c] for c in range(arr.shape[1])], axis=1)


def plain_batch(mesh: LocalMesh, layout: DofLayout, cells: IntArray) -> Batch:
    """Batch of plain cells: functions N_a, dofs (DX.., DY.., [DZ..])."""
    nodes = mesh.cell_nodes[cells]
    loc = _blocked(layout.u_local, nodes)
    return Batch(cells, loc, _blocked(layout.u_global, nodes))


def enriched_batch(mesh: LocalMesh, layout: DofLayout, cells: IntArray) -> Batch:
    """Batch of cells with functions (N_a, psi_a N_a): dofs (DX.., H1X.., DY.., H1Y..,
    [DZ.., H1Z..]), ``(ne, 2 d nn)``."""
    return Batch(cells, enriched_dofs(layout, mesh.cell_nodes[cells]),
                 enriched_dofs(layout, mesh.cell_nodes[cells], glob=True))


def enriched_dofs(layout: DofLayout, nodes: IntArray, glob: bool = False) -> IntArray:
    """Local (absent Heaviside dofs: ``layout.dummy``) or global (absent: -1) dofs
    ``(k, 2 d m)`` of the functions (N_a, psi_a N_a) of nodes ``(k, m)``, blocked by
    component: (DX.., H1X.., DY.., H1Y.., [DZ.., H1Z..])."""
    if glob:
        u, h = layout.u_global, layout.h_global
    else:
        u, h = layout.u_local, np.where(layout.h_local >= 0, layout.h_local, layout.dummy)
    return np.concatenate([a[nodes, c] for c in range(layout.dim) for a in (u, h)], axis=1)


class PlainStiffness:
    """Stiffness of plain cells of one element type and material."""

    def __init__(self, el: Element, D: FloatArray) -> None:
        self.el = el
        self.C = elasticity.tensor(D)
        # exact rules for affine cells; the same rule for curved ones
        self.q, self.wq = el.quadrature(el.stiffness_degree)
        self.q_gen, self.wq_gen = el.quadrature(4)
        self.basis = elasticity.affine_basis(elasticity.reference_products(el.dshape(self.q), self.wq), self.C)

    def __call__(self, x: FloatArray, aff: BoolArray | None = None) -> FloatArray:
        """Element matrices ``(ne, d nn, d nn)`` of cells ``x (ne, nn, d)`` (read-only);
        ``aff``: which cells are affine (:func:`elements.affine_cells`) if known."""
        el = self.el
        aff = affine_cells(el, x) if aff is None else aff
        if aff.all():               # no copy into a new array (may be a broadcast view)
            return elasticity.affine_stiffness(el.jacobians(x, el.ref_nodes[:1])[:, 0], self.basis)
        K = np.empty((len(x), el.dim * el.nn, el.dim * el.nn))
        if aff.any():
            xa = x[aff]
            J = el.jacobians(xa, el.ref_nodes[:1])[:, 0]
            K[aff] = elasticity.affine_stiffness(J, self.basis)
        if (~aff).any():
            xg = x[~aff]
            J = el.jacobians(xg, self.q_gen)
            G, det = physical_gradients(el.dshape(self.q_gen)[None], J)
            K[~aff] = elasticity.stiffness(G, self.wq_gen[None] * det, self.C)
        return K


def enriched_gradients(G_std: FloatArray, psi: FloatArray) -> FloatArray:
    """Gradients ``(ne, nq, 2 nn, d)`` of (N_a, psi_a N_a) from those of N_a,
    ``G_std (ne, nq, nn, d)``, and Heaviside weights ``psi (ne, nq, nn)``."""
    return np.concatenate([G_std, psi[..., None] * G_std], axis=2)


def add_matrices(A: PETSc.Mat, batch: Batch, K: FloatArray, rows: slice = slice(None)) -> None:
    """``A += K`` for the cells ``rows`` of ``batch`` (ADD_VALUES, negatives ignored)."""
    from xfemcontact._petsc import PETSc

    g = batch.glob[rows].astype(PETSc.IntType)
    if len(g) == 0:               # petsc4py divides by the batch size
        return
    # petsc4py copies a non-contiguous (broadcast) K element by element: copy it first
    A.setValuesRCV(g, g, np.ascontiguousarray(K), addv=PETSc.InsertMode.ADD_VALUES)


def add_lift(r_local: FloatArray, batch: Batch, K: FloatArray, x_bc: FloatArray,
             rows: slice = slice(None)) -> None:
    """Accumulate ``K_e @ x_bc,e`` (imposed values) into the local array ``r_local``."""
    loc = batch.local[rows]
    xe = x_bc[loc]
    active = np.any(xe != 0.0, axis=1)
    if active.any():
        fe = np.einsum("eij,ej->ei", K[active], xe[active])
        np.add.at(r_local, loc[active], fe)


def assemble_plain(mesh: LocalMesh, batch: Batch, stiffness: PlainStiffness, A: PETSc.Mat,
                   r_local: FloatArray, x_bc: FloatArray) -> None:
    """Add the stiffness of a plain batch to ``A`` and its Dirichlet lift to ``r_local``."""
    x = mesh.x
    nodes = mesh.cell_nodes
    for s in range(0, len(batch), CHUNK):
        rows = slice(s, min(s + CHUNK, len(batch)))
        cells = batch.cells[rows]
        K = stiffness(x[nodes[cells]], mesh.affine[cells])
        add_matrices(A, batch, K, rows)
        add_lift(r_local, batch, K, x_bc, rows)
