"""Where the multipliers of each interface element live in the global system.

The carriers of a segment cell (see :mod:`xfemcontact.contact.space`) are
vertices that may be owned by another process (merged vertices share the dof
of their representative).  This module finds the global LAGS_C index of every
carrier (LAGS_F1 is the next index) and, for the matrix pattern, the point of
each carrier: a local node, or a "remote point" numbered after the local nodes.
In 3-D a carrier holds LAGS_C, LAGS_F1, LAGS_F2 (the next two indices).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.contact.space import MultiplierSpace
    from xfemcontact.dofs.layout import DofLayout
    from xfemcontact.mesh.plex import LocalMesh

    IntArray = NDArray[np.int64]


@dataclass
class MultiplierDofs:
    """Where the multipliers of the interface elements are (see the module documentation)."""

    rep_index: IntArray          # (k, m) global LAGS_C index of each segment cell's carriers (-1 pad)
    #: (global index, dofs per point, owner rank), each ``(r,)``, of the remote carriers
    remote_points: tuple[IntArray, IntArray, IntArray]
    element_points: IntArray     # (k, nn + m) pattern points of each interface element


def multiplier_dofs(mesh: LocalMesh, layout: DofLayout, space: MultiplierSpace,
                    cells: IntArray) -> MultiplierDofs:
    """The :class:`MultiplierDofs` of the interface elements of the local ``cells (k,)``
    (one row per element: the cells of the segments in 2-D, of the facets in 3-D;
    collective)."""
    own = layout.multiplier & mesh.node_owned
    mpi = mesh.comm.tompi4py()
    parts = mpi.allgather((mesh.node_ids[own], layout.lag_global[own, 0]))
    ids = np.concatenate([p[0] for p in parts])
    idx = np.concatenate([p[1] for p in parts])
    owner = np.concatenate([np.full(len(p[0]), r) for r, p in enumerate(parts)])
    order = np.argsort(ids)
    ids, idx, owner = ids[order], idx[order], owner[order]
    co = space.carriers_of
    live = co >= 0
    rep = space.representative(np.where(live, co, space.ids[0]))
    pos = np.searchsorted(ids, rep)
    rep_index = np.where(live, idx[pos], -1)
    # carriers as points of the matrix pattern: a local node, or a remote point
    vloc = np.argsort(mesh.node_ids[: mesh.n_vertices])
    vids = mesh.node_ids[: mesh.n_vertices][vloc]
    if len(vids):
        j = np.minimum(np.searchsorted(vids, rep), len(vids) - 1)
        local = (vids[j] == rep) & live
        point = np.where(local, vloc[j], -1)
    else:
        local = np.zeros(rep.shape, bool)
        point = np.full(rep.shape, -1)
    remote_ids: IntArray
    remote_ids, rpos = np.unique(rep[~local & live], return_inverse=True)
    point[~local & live] = len(mesh.x) + rpos
    rp = np.searchsorted(ids, remote_ids)
    remote = (idx[rp], np.full(len(rp), mesh.dim), owner[rp])      # LAGS_C, LAGS_F1, [LAGS_F2]
    points = np.concatenate([mesh.cell_nodes[cells], point], axis=1)
    return MultiplierDofs(rep_index, remote, points)
