"""Structured quadratic meshes of a rectangle, built with vectorised NumPy.

The nodes sit on the "fine grid" of ``(2 nx + 1) x (2 ny + 1)`` positions
(vertices at even fine indices, mid-edge nodes between them), numbered with x
running fastest.  QUAD8 meshes skip the square centres; TRIA6 meshes use them
as the mid-nodes of the diagonals.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from xfemcontact.errors import MeshError
from xfemcontact.mesh.raw import CELL_TYPES, RawMesh

if TYPE_CHECKING:
    from numpy.typing import NDArray

    IntArray = NDArray[np.int64]

DIAGONALS = ("alternate", "right", "left")

# Local nodes of the cells of the square whose lower-left fine index is (2i, 2j),
# as fine-grid offsets (di, dj); vertices counter-clockwise, then mid-edge nodes.
_QUAD8 = np.array([[(0, 0), (2, 0), (2, 2), (0, 2), (1, 0), (2, 1), (1, 2), (0, 1)]])
# diagonal from lower-left to upper-right ("right", "/")
_TRIA6_RIGHT = np.array([[(0, 0), (2, 0), (2, 2), (1, 0), (2, 1), (1, 1)],
                         [(0, 0), (2, 2), (0, 2), (1, 1), (1, 2), (0, 1)]])
# diagonal from lower-right to upper-left ("left", "\")
_TRIA6_LEFT = np.array([[(0, 0), (2, 0), (0, 2), (1, 0), (1, 1), (0, 1)],
                        [(2, 0), (2, 2), (0, 2), (2, 1), (1, 2), (1, 1)]])


def rectangle(nx: int, ny: int, x: tuple[float, float] = (0.0, 10.0), y: tuple[float, float] = (0.0, 10.0),
              cell: str = "QUAD8", diagonal: str = "alternate") -> RawMesh:
    """Structured ``nx`` x ``ny`` mesh of the rectangle ``x[0]..x[1]`` x ``y[0]..y[1]`` (m).

    ``cell`` is "QUAD8" (8-node serendipity squares, ``nx*ny`` cells,
    ``(2nx+1)(2ny+1) - nx*ny`` nodes) or "TRIA6" (each square split in two,
    ``2*nx*ny`` cells, ``(2nx+1)(2ny+1)`` nodes).  ``diagonal`` (TRIA6 only)
    chooses the split: "right" along the diagonal from the lower-left to the
    upper-right corner of every square, "left" from the lower-right to the
    upper-left corner, "alternate" (default) "right" in the 1st, 3rd, 5th ...
    column of squares from ``x[0]`` and "left" in the others, the same in
    every row.  "alternate" is the triangulation of code_aster's
    ``ssnv509b.mmed``: ``rectangle(20, 20, cell="TRIA6")`` gives its 800
    triangles (up to node and cell numbering).

    Groups (code_aster's names and plain ones): edge groups "LIG1" = "bottom"
    (y = y[0]), "LIG2" = "right" (x = x[1]), "LIG3" = "top", "LIG4" = "left",
    rows ``(a, b, mid)`` running counter-clockwise around the rectangle; cell
    group "SURF" (all cells); node groups "P1".."P4" at the corners
    ``(x0, y0), (x1, y0), (x1, y1), (x0, y1)``.  Cells are counter-clockwise;
    the mesh is valid by construction (``check()`` is not called).
    """
    _check_args(nx, ny, x, y, cell, diagonal)
    fx, fy = 2 * nx + 1, 2 * ny + 1
    X, Y = np.meshgrid(np.linspace(*x, fx), np.linspace(*y, fy))
    number = np.arange(fx * fy).reshape(fy, fx)              # [J, I] fine grid
    if cell == "QUAD8":
        number[1::2, 1::2] = -1                              # no centre node
        keep = number.ravel() >= 0
        number[number >= 0] = np.arange(np.count_nonzero(keep))
    else:
        keep = np.ones(fx * fy, bool)
    points = np.c_[X.ravel(), Y.ravel()][keep]
    cells = _cells(number, nx, ny, cell, diagonal)
    edges = _boundary_edges(number)
    corners = number[[0, 0, -1, -1], [0, -1, -1, 0]]
    return RawMesh(
        points=points, cell_type=cell, cells=cells,
        cell_groups={"SURF": np.arange(len(cells))},
        edge_groups={**{f"LIG{k + 1}": e for k, e in enumerate(edges)},
                     **{s: e.copy() for s, e in zip(("bottom", "right", "top", "left"), edges)}},
        node_groups={f"P{k + 1}": corners[k:k + 1].copy() for k in range(4)},
        source=f"<rectangle {nx}x{ny} {cell}>")


def _check_args(nx: int, ny: int, x: tuple[float, float], y: tuple[float, float], cell: str,
                diagonal: str) -> None:
    where = "rectangle"
    for name, n in (("nx", nx), ("ny", ny)):
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
            raise MeshError(f"{where}: {name} must be a positive integer (got {n!r})")
    for name, (a, b) in (("x", x), ("y", y)):
        if not (np.isfinite(a) and np.isfinite(b) and a < b):
            raise MeshError(f"{where}: {name} must be an interval (min, max) with "
                            f"min < max (got {(a, b)!r})")
    if cell not in CELL_TYPES:
        raise MeshError(f"{where}: cell must be one of {', '.join(CELL_TYPES)} (got {cell!r})")
    if diagonal not in DIAGONALS:
        raise MeshError(f"{where}: diagonal must be one of {', '.join(DIAGONALS)} "
                        f"(got {diagonal!r})")


def _cells(number: IntArray, nx: int, ny: int, cell: str, diagonal: str) -> IntArray:
    """Connectivity ``(n_cells, 8|6)``: squares row by row, x fastest, 1 or 2 cells each."""
    j, i = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    i, j = i.ravel(), j.ravel()                              # (nsq,) square indices
    if cell == "QUAD8":
        local = np.broadcast_to(_QUAD8, (len(i),) + _QUAD8.shape)
    else:
        right = {"right": np.ones_like(i, bool), "left": np.zeros_like(i, bool),
                 "alternate": i % 2 == 0}[diagonal]
        local = np.where(right[:, None, None, None], _TRIA6_RIGHT, _TRIA6_LEFT)
    fi = 2 * i[:, None, None] + local[..., 0]                # (nsq, per square, nn)
    fj = 2 * j[:, None, None] + local[..., 1]
    return number[fj, fi].reshape(-1, local.shape[-2])


def _boundary_edges(number: IntArray) -> list[IntArray]:
    """SEG3 rows ``(a, b, mid)`` of the bottom, right, top and left sides, counter-clockwise."""
    sides = (number[0, :], number[:, -1], number[-1, ::-1], number[::-1, 0])
    return [np.c_[s[0:-1:2], s[2::2], s[1::2]] for s in sides]
