"""Matrix creation with preallocation computed from the element couplings.

Every element couples all dofs of a list of points (its nodes, and for cut
elements the vertices that carry its multipliers, which after merging may sit
outside the element).  Point adjacency is one sparse product ``E^T E`` of the
element-point incidence; each row of a point gets the free dofs of its adjacent
points, split into the diagonal and off-diagonal blocks of the owner of the row.
Rows of points owned by another process are summed onto the owner through the
point SF.  Counts are upper bounds where two processes see the same coupling
(partition boundaries), never lower ones.

With ``symmetric`` the matrix is SBAIJ (block size 1): only the upper triangle
is stored (the lower entries of element matrices are ignored), and a row
counts only the columns at or after it: the adjacent points whose dofs come
later in the global numbering, and the point's own dofs from the row's on.

Points outside this process's chart (merged multipliers held elsewhere) are
"remote points": they are appended after the local nodes with their owner rank,
global offset and number of free dofs, and their rows travel by MPI to the owner.
"""
import numpy as np
import scipy.sparse as sp

from xfemcontact._petsc import PETSc


class PointSpace:
    """Local nodes followed by remote points, with their global dof ranges.

    ``first``: global index of each point's first free dof (-1 if none),
    ``nfree``: number of free (unconstrained) dofs, ``owner``: owning rank.
    """

    def __init__(self, layout, remote=None):
        mesh = layout.mesh
        glob = np.c_[layout.u_global, layout.h_global, layout.lag_global]
        nfree = (glob >= 0).sum(axis=1)
        first = np.where(nfree > 0, np.where(glob >= 0, glob, np.iinfo(np.int64).max).min(axis=1), -1)
        owner = np.full(len(mesh.x), mesh.comm.rank, dtype=np.int64)
        owner[~mesh.node_owned] = _ghost_owners(mesh)
        self.n_local = len(mesh.x)
        if remote is not None and len(remote[0]):
            first = np.r_[first, remote[0]]
            nfree = np.r_[nfree, remote[1]]
            owner = np.r_[owner, remote[2]]
        self.first, self.nfree, self.owner = first, nfree, owner


def _ghost_owners(mesh):
    """Owner rank of every local node that this process does not own."""
    if mesh.comm.size == 1:
        return np.zeros(0, dtype=np.int64)
    _, leaves, remote = mesh.point_sf.getGraph()
    owner_of_point = np.full(mesh.chart[1], mesh.comm.rank, dtype=np.int64)
    owner_of_point[np.asarray(leaves)] = np.asarray(remote)[:, 0]
    return owner_of_point[mesh.node_points[~mesh.node_owned]]


def create_matrix(layout, blocks, remote=None, symmetric=False):
    """A preallocated matrix for the element couplings ``blocks``: AIJ, or SBAIJ
    (upper triangle) when ``symmetric``.

    ``blocks``: list of int arrays ``(ne, k)`` of point indices in the point
    space (local nodes, then remote points; -1 entries are ignored).
    ``remote``: (first, nfree, owner) of remote points, or None.
    """
    space = PointSpace(layout, remote)
    d, o = _point_counts(space, blocks, upper=symmetric)
    d_nnz, o_nnz = _dof_counts(layout, space, d, o, upper=symmetric)
    comm = layout.mesh.comm
    n, N = layout.owned_size, layout.global_size
    nnz = (d_nnz.astype(PETSc.IntType), o_nnz.astype(PETSc.IntType))
    if symmetric:
        A = PETSc.Mat().createSBAIJ(((n, N), (n, N)), 1, nnz=nnz, comm=comm)
        A.setOption(PETSc.Mat.Option.IGNORE_LOWER_TRIANGULAR, True)
    else:
        A = PETSc.Mat().createAIJ(((n, N), (n, N)), nnz=nnz, comm=comm)
    A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
    A.setOption(PETSc.Mat.Option.KEEP_NONZERO_PATTERN, True)
    return A


def _incidence(blocks, npoints):
    rows, cols = [], []
    start = 0
    for b in blocks:
        b = np.asarray(b, dtype=np.int64)
        if b.size == 0:
            continue
        r = np.repeat(np.arange(start, start + len(b)), b.shape[1])
        c = b.ravel()
        keep = c >= 0
        rows.append(r[keep])
        cols.append(c[keep])
        start += len(b)
    if not rows:
        return sp.csr_matrix((0, npoints))
    r, c = np.concatenate(rows), np.concatenate(cols)
    E = sp.csr_matrix((np.ones(len(r), dtype=np.int8), (r, c)), shape=(start, npoints))
    E.sum_duplicates()
    E.data[:] = 1
    return E


def _point_counts(space, blocks, upper=False):
    """Per point: free dofs of adjacent points owned like the point (d) or not (o).

    ``upper``: only the other points whose dofs come after the point's (the
    point's own dofs are added per row by :func:`_expand`).
    """
    npts = len(space.first)
    E = _incidence(blocks, npts).astype(np.int32)
    A = E.T @ E
    if A.format != "csr":                          # symmetric: its CSC arrays are its CSR arrays
        A = A.tocsc()
        A = sp.csr_matrix((A.data, A.indices, A.indptr), shape=A.shape)
    A.data[:] = 1                                  # adjacency, not multiplicity
    if upper:
        row_first = np.repeat(space.first, np.diff(A.indptr))    # first dof of each entry's row
        A.data[space.first[A.indices] <= row_first] = 0
        A.eliminate_zeros()
    total = A @ space.nfree
    owners = np.unique(space.owner)
    if len(owners) <= 1:
        return total, np.zeros(npts, dtype=np.int64)
    d = np.zeros(npts, dtype=np.int64)
    for r in owners:                               # a few ranks: one sparse product each
        rows = space.owner == r
        d[rows] = A[rows] @ (space.nfree * (space.owner == r))
    return d, total - d


def _dof_counts(layout, space, d, o, upper=False):
    """Sum counts onto owners and expand them to every owned dof row."""
    mesh = layout.mesh
    comm = mesh.comm
    nl = space.n_local
    rank = comm.rank
    if comm.size > 1:
        d_loc, o_loc = _reduce_to_owners(mesh, d[:nl], o[:nl])
        received = _send_remote_rows(comm, space, d[nl:], o[nl:])
    else:
        d_loc, o_loc = d[:nl], o[:nl]
        received = []
    n = layout.owned_size
    d_nnz = np.zeros(n, dtype=np.int64)
    o_nnz = np.zeros(n, dtype=np.int64)
    own = (space.owner[:nl] == rank) & (space.nfree[:nl] > 0)
    _expand(d_nnz, o_nnz, space.first[:nl][own] - layout.ownership_start, space.nfree[:nl][own],
            d_loc[own], o_loc[own], upper)
    for first, nfree, dd, oo in received:
        _expand(d_nnz, o_nnz, first - layout.ownership_start, nfree, dd, oo, upper)
    np.minimum(d_nnz, n, out=d_nnz)
    np.minimum(o_nnz, layout.global_size - n, out=o_nnz)
    return d_nnz, o_nnz


def _expand(d_nnz, o_nnz, start, count, d, o, upper=False):
    """Point counts onto each of the point's ``count`` dof rows from ``start``; with
    ``upper`` row ``i`` of a point also holds its own dofs ``i ..``."""
    if len(start) == 0:
        return
    i = _ranges(count)
    rows = np.repeat(start, count) + i
    d_nnz[rows] += np.repeat(d, count)
    o_nnz[rows] += np.repeat(o, count)
    if upper:
        d_nnz[rows] += np.repeat(count, count) - i


def _ranges(count):
    """Concatenated aranges ``[0..count[0]), [0..count[1]) ...``."""
    total = int(count.sum())
    offsets = np.repeat(np.cumsum(count) - count, count)
    return np.arange(total) - offsets


def _reduce_to_owners(mesh, d, o):
    """Add ghost copies' counts onto the owners' counts (point SF, MPI_SUM).

    A ghost row is seen by the owner with a different diagonal/off-diagonal
    split; counts are only upper bounds, so the sum of both is added to each.
    """
    from mpi4py import MPI

    sf = mesh.point_sf
    nchart = mesh.chart[1]
    leaf = np.zeros((nchart, 2), dtype=np.int64)
    leaf[mesh.node_points[~mesh.node_owned]] = np.c_[d, o][~mesh.node_owned]
    root = np.zeros((nchart, 2), dtype=np.int64)
    root[mesh.node_points] = np.c_[d, o]
    root[mesh.node_points[~mesh.node_owned]] = 0
    total = leaf.sum(axis=1).copy()
    add = np.zeros(nchart, dtype=np.int64)
    sf.reduceBegin(MPI.INT64_T, total, add, MPI.SUM)
    sf.reduceEnd(MPI.INT64_T, total, add, MPI.SUM)
    extra = add[mesh.node_points]
    return d + extra, o + extra


def _send_remote_rows(comm, space, d, o):
    """Send rows of remote points to their owners; receive ours."""
    mpi = comm.tompi4py()
    nl = space.n_local
    owner = space.owner[nl:]
    out = [[] for _ in range(mpi.size)]
    for r in np.unique(owner):
        k = owner == r
        out[r] = (space.first[nl:][k], space.nfree[nl:][k], d[k] + o[k], d[k] + o[k])
    recv = mpi.alltoall(out)
    return [x for x in recv if len(x)]
