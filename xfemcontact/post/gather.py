"""Gather distributed node and cell data on rank 0, ordered by input-mesh index.

Results files are written once for the whole mesh whatever the number of
processes; ordering by the input indices makes them identical for every
partition.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Iterable

import numpy as np

if TYPE_CHECKING:
    from typing import TypeVar

    from numpy.typing import ArrayLike, NDArray
    from petsc4py import PETSc

    from xfemcontact.mesh.plex import LocalMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    Item = TypeVar("Item")


def gather_nodes(mesh: LocalMesh,
                 **arrays: ArrayLike) -> tuple[IntArray, FloatArray, dict[str, NDArray[Any]]] | None:
    """On rank 0: ``(node_ids, x, {name: array})`` of every node once; None elsewhere."""
    own = mesh.node_owned
    payload = (mesh.node_ids[own], mesh.x[own], {k: np.asarray(v)[own] for k, v in arrays.items()})
    parts = mesh.comm.tompi4py().gather(payload, root=0)
    if parts is None:
        return None
    ids = np.concatenate([p[0] for p in parts])
    order = np.argsort(ids, kind="stable")
    x = np.concatenate([p[1] for p in parts])[order]
    data = {k: np.concatenate([p[2][k] for p in parts])[order] for k in arrays}
    return ids[order], x, data


def gather_cells(mesh: LocalMesh,
                 **arrays: ArrayLike) -> tuple[IntArray, IntArray, dict[str, NDArray[Any]]] | None:
    """On rank 0: ``(cell_ids, node_ids (nc, nn), {name: array})``; None elsewhere."""
    payload = (mesh.cell_ids, mesh.node_ids[mesh.cell_nodes], {k: np.asarray(v) for k, v in arrays.items()})
    parts = mesh.comm.tompi4py().gather(payload, root=0)
    if parts is None:
        return None
    ids = np.concatenate([p[0] for p in parts])
    order = np.argsort(ids, kind="stable")
    conn = np.concatenate([p[1] for p in parts])[order]
    data = {k: np.concatenate([p[2][k] for p in parts])[order] for k in arrays}
    return ids[order], conn, data


def gather_list(comm: PETSc.Comm, items: Iterable[Item]) -> list[Item] | None:
    """Concatenate per-process lists on rank 0 (None elsewhere)."""
    parts = comm.tompi4py().gather(list(items), root=0)
    return None if parts is None else [x for p in parts for x in p]
