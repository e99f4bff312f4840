"""What the 2-D and 3-D DMPlex builds share: the label conventions of mesh groups and
the points another process owns."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from xfemcontact._petsc import PETSc

if TYPE_CHECKING:
    from numpy.typing import NDArray

    IntArray = NDArray[np.int64]

#: labels PETSc creates itself; never confused with mesh groups
_INTERNAL_LABELS = {"depth", "celltype", "boundary"}
_BOUNDARY = "boundary"
ENTITY, NODE = 1, 2      # label values: cells/faces/edges of a group, nodes of a node group


def set_stratum(label: PETSc.DMLabel, value: int, points: IntArray) -> None:
    """Give the DMPlex ``points`` the ``value`` of ``label`` (repeats allowed)."""
    pts = np.unique(points).astype(PETSc.IntType)
    label.setStratumIS(value, PETSc.IS().createGeneral(pts, comm=PETSc.COMM_SELF))


def point_sf_leaves(dm: PETSc.DMPlex) -> IntArray:
    """Local points owned by another process (leaves of the point SF)."""
    if dm.comm.size == 1:
        return np.zeros(0, dtype=np.int64)
    nroots, leaves, _ = dm.getPointSF().getGraph()
    if nroots < 0 or leaves is None:
        return np.zeros(0, dtype=np.int64)
    return np.asarray(leaves, dtype=np.int64)
