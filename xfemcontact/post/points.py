"""Points of the post-processing meshes: merged by position (one tolerance for all)."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]

#: points closer than this fraction of the mesh's bounding-box diagonal are one point
MERGE_TOL = 1e-11


def diagonal(xs: FloatArray) -> float:
    """Bounding-box diagonal of ``xs (S, d)``, 1 if empty or a single point."""
    if len(xs) == 0:
        return 1.0
    # column by column: numpy reduces an (S, 2) array along axis 0 ten times slower
    sides = [np.ptp(xs[:, i]) for i in range(xs.shape[1])]
    if len(sides) == 2:
        return float(np.hypot(*sides)) or 1.0
    return float(np.sqrt(sum(a * a for a in sides))) or 1.0


def merge_points(xs: FloatArray, diag: float | None = None) -> IntArray:
    """Label ``(S,)`` of each point of ``xs (S, d)``: equal for points closer than
    MERGE_TOL times the bounding-box diagonal, numbered by first appearance."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    n = len(xs)
    if n == 0:
        return np.zeros(0, np.int64)
    diag = diagonal(xs) if diag is None else diag
    pairs = cKDTree(xs).query_pairs(MERGE_TOL * diag, output_type="ndarray")
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    _, first, inv = np.unique(lab, return_index=True, return_inverse=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[inv]
