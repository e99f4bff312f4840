"""METIS partitioning of the mesh, handed to DMPlex through a shell partitioner.

Debian's PETSc has no ParMETIS partitioner and Debian's MUMPS no METIS ordering;
METIS itself (through pymetis) partitions the cell dual graph (cells sharing an
edge in 2-D, a face in 3-D) on rank 0, with weights so that cut cells, which carry sub-cell
quadrature and interface terms, count for their extra work.  Any other PETSc
partitioner stays available with ``-petscpartitioner_type ptscotch|simple``.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike, NDArray
    from petsc4py import PETSc

    from xfemcontact.case.formula import Formula
    from xfemcontact.mesh.raw import RawMesh

    IntArray = NDArray[np.int64]

#: work of a cut cell relative to a plain one (sub-cells: ~2 x 3 sub-triangles
#: of 12-25 points, plus the interface terms)
CUT_CELL_WEIGHT = 8


def dual_graph(cell_vertices: IntArray, sides: IntArray | None = None) -> tuple[IntArray, IntArray]:
    """CSR dual graph (``xadj``, ``adjncy``) of cells sharing a side.

    ``cell_vertices (ne, nv)``: vertex indices of each cell; ``sides (ns, m)``: the
    local vertices of each side of a cell (3-D: its faces); default: the edges of a
    polygon whose vertices are counter-clockwise.
    """
    ne, nv = cell_vertices.shape
    if sides is None:
        sides = np.c_[np.arange(nv), np.roll(np.arange(nv), -1)]
    rows = np.sort(cell_vertices[:, sides].reshape(-1, sides.shape[1]), axis=1)     # (ne ns, m)
    cell = np.repeat(np.arange(ne), len(sides))
    order = np.lexsort(rows.T[::-1])                      # stable, by the sorted vertices
    r, c = rows[order], cell[order]
    twin = np.nonzero((r[1:] == r[:-1]).all(axis=1))[0]
    i, j = c[twin], c[twin + 1]
    src = np.r_[i, j]
    dst = np.r_[j, i]
    order = np.argsort(src, kind="stable")
    xadj = np.r_[0, np.cumsum(np.bincount(src, minlength=ne))]
    return xadj.astype(np.int64), dst[order].astype(np.int64)


def metis_parts(cell_vertices: IntArray, nparts: int, weights: ArrayLike | None = None,
                sides: IntArray | None = None) -> IntArray:
    """Part of every cell (``(ne,)`` ints in [0, nparts)); ``sides``: see :func:`dual_graph`."""
    if nparts == 1:
        return np.zeros(len(cell_vertices), dtype=np.int64)
    import pymetis

    xadj, adjncy = dual_graph(cell_vertices, sides)
    vw = None if weights is None else np.asarray(weights, dtype=np.int64)
    if hasattr(pymetis, "CSRAdjacency"):      # arrays as they are (lists cost twice the METIS time)
        _, parts = pymetis.part_graph(nparts, adjacency=pymetis.CSRAdjacency(xadj, adjncy), vweights=vw)
    else:
        _, parts = pymetis.part_graph(nparts, xadj=xadj.tolist(), adjncy=adjncy.tolist(),
                                      vweights=None if vw is None else vw.tolist())
    return np.asarray(parts, dtype=np.int64)


def cut_cell_weights(raw: RawMesh, levelset: Formula | None) -> IntArray:
    """Cell weights: ``CUT_CELL_WEIGHT`` for cells whose nodes change sign, else 1."""
    if levelset is None:
        return np.ones(len(raw.cells), dtype=np.int64)
    from xfemcontact.fem.coordinates import coordinates

    phi = levelset(**coordinates(raw.points))[raw.cells]
    cut = (phi.max(axis=1) >= 0) & (phi.min(axis=1) <= 0)
    return np.where(cut, CUT_CELL_WEIGHT, 1).astype(np.int64)


def shell_partition(dm: PETSc.DMPlex, cell_vertices: IntArray, weights: IntArray,
                    comm: PETSc.Comm, sides: IntArray | None = None) -> tuple[list[int], list[float] | None]:
    """Set ``dm``'s partitioner to the METIS partition (computed on rank 0, where
    ``cell_vertices (ne, nv)`` and ``weights (ne,)`` are significant; ``sides``: see
    :func:`dual_graph`).

    Returns the per-process (cells, weight) on every rank.
    """
    from xfemcontact._petsc import PETSc

    mpi = comm.tompi4py()
    n = mpi.size
    if mpi.rank == 0:
        parts = metis_parts(cell_vertices, n, weights, sides)
        order = np.argsort(parts, kind="stable")
        sizes = np.bincount(parts, minlength=n)
        load = np.bincount(parts, weights=weights, minlength=n)
    else:
        order, sizes, load = np.zeros(0, np.int64), np.zeros(n, np.int64), None
    part = dm.getPartitioner()
    part.setType(PETSc.Partitioner.Type.SHELL)
    part.setShellPartition(n, sizes.astype(PETSc.IntType), order.astype(PETSc.IntType))
    return mpi.bcast((sizes.tolist(), None if load is None else load.tolist()), root=0)
