"""Structured quadratic meshes of a rectangle (2-D) and of a box (3-D), built with
vectorised NumPy.

The nodes sit on the "fine grid" of ``(2 nx + 1) x (2 ny + 1)`` positions
(vertices at even fine indices, mid-edge nodes between them), numbered with x
running fastest.  QUAD8 meshes skip the square centres; TRIA6 meshes use them
as the mid-nodes of the diagonals.  Boxes (:func:`box`) do the same on a 3-D grid.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from xfemcontact.errors import MeshError
from xfemcontact.mesh.raw import RawMesh

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.fem.elements import Element

    IntArray = NDArray[np.int64]

DIAGONALS = ("alternate", "right", "left")
#: cells of the rectangles and of the boxes
RECTANGLE_CELLS = ("QUAD8", "TRIA6")
BOX_CELLS = ("HEXA20", "TETRA10")

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
    if cell not in RECTANGLE_CELLS:
        raise MeshError(f"{where}: cell must be one of {', '.join(RECTANGLE_CELLS)} (got {cell!r})")
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


# -- boxes (3-D) ------------------------------------------------------------------------
#: face groups of a box: plain name, code_aster's name (SSNV182's meshes) where it has
#: one, the axis and the end (0 = min, 1 = max) of the plane
BOX_FACES = (("left", None, 0, 0), ("right", None, 0, 1), ("front", None, 1, 0),
             ("back", None, 1, 1), ("bottom", "SURFINF", 2, 0), ("top", "SURFSUP", 2, 1))


def box(nx: int, ny: int, nz: int, x: tuple[float, float] = (0.0, 1.0),
        y: tuple[float, float] = (0.0, 1.0), z: tuple[float, float] = (0.0, 1.0),
        cell: str = "HEXA20") -> RawMesh:
    """Structured ``nx`` x ``ny`` x ``nz`` mesh of the box ``x`` x ``y`` x ``z`` (intervals, m).

    ``cell`` is "HEXA20" (``nx ny nz`` serendipity hexahedra) or "TETRA10" (each
    hexahedron split into 6 tetrahedra around its diagonal from the (x0, y0, z0)
    corner, the same in every one, so the faces match).  Nodes sit on the fine grid
    of ``(2 nx + 1)(2 ny + 1)(2 nz + 1)`` positions, x fastest, then y, then z;
    HEXA20 meshes skip the face and cube centres.

    Groups: cell group "VOL" (all cells, code_aster's name); face groups "left"
    (x = x0), "right" (x = x1), "front" (y = y0), "back" (y = y1), "bottom" (z = z0)
    = "SURFINF", "top" (z = z1) = "SURFSUP" (the names of code_aster's SSNV182
    meshes), rows in the face element's order (QUAD8 or TRIA6) with the outward
    normal by the right-hand rule; node groups "P1".."P8" at the corners, P1..P4
    at z0 counter-clockwise from (x0, y0), P5..P8 above them.  Cells are direct;
    the mesh is valid by construction (``check()`` is not called).
    """
    _check_box_args(nx, ny, nz, x, y, z, cell)
    from xfemcontact.fem.elements import element

    el = element(cell)
    shape = (2 * nz + 1, 2 * ny + 1, 2 * nx + 1)
    k, j, i = np.meshgrid(*(np.arange(n) for n in shape), indexing="ij")
    keep = ((i % 2) + (j % 2) + (k % 2) <= 1) if cell == "HEXA20" else np.ones(shape, bool)
    number = np.full(shape, -1, np.int64)
    number[keep] = np.arange(np.count_nonzero(keep))
    coords = [np.linspace(*lim, n)[idx[keep]] for lim, n, idx in zip((x, y, z), shape[::-1], (i, j, k))]
    points = np.stack(coords, axis=1)
    local = _box_template(cell)                                            # (per cube, nn, 3)
    ck, cj, ci = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    origin = 2 * np.stack([ci.ravel(), cj.ravel(), ck.ravel()], axis=1)     # (ncubes, 3) fine (i, j, k)
    fine = origin[:, None, None, :] + local[None]                           # (ncubes, per, nn, 3)
    fine = fine.reshape(-1, el.nn, 3)
    cells = number[fine[..., 2], fine[..., 1], fine[..., 0]]
    faces = _box_faces(el, cells, fine, (2 * nx, 2 * ny, 2 * nz))
    corner_fine = [(0, 0, 0), (2 * nx, 0, 0), (2 * nx, 2 * ny, 0), (0, 2 * ny, 0)]
    corner_fine += [(a, b, 2 * nz) for a, b, _ in corner_fine]
    return RawMesh(
        points=points, cell_type=cell, cells=cells,
        cell_groups={"VOL": np.arange(len(cells))},
        face_groups=faces,
        node_groups={f"P{n + 1}": np.array([number[c, b, a]]) for n, (a, b, c) in enumerate(corner_fine)},
        source=f"<box {nx}x{ny}x{nz} {cell}>")


def _box_template(cell: str) -> IntArray:
    """Fine-grid offsets ``(per cube, nn, 3)`` of the cells of one cube, each direct."""
    from xfemcontact.fem.elements import element

    el = element(cell)
    if cell == "HEXA20":
        return (el.ref_nodes + 1).astype(np.int64)[None]
    import itertools

    tets = []
    for order in itertools.permutations(range(3)):       # Kuhn: paths 0 -> (1, 1, 1)
        path = [np.zeros(3, np.int64)]
        for axis in order:
            path.append(path[-1] + 2 * np.eye(3, dtype=np.int64)[axis])
        v = np.array(path)
        nodes = np.r_[v, (v[el.edges[:, 0]] + v[el.edges[:, 1]]) // 2]
        if el.jacobian_dets(nodes[None].astype(float), el.ref_nodes[:1])[0, 0] < 0:
            nodes = nodes[el.reverse]
        tets.append(nodes)
    return np.array(tets)


def _box_faces(el: Element, cells: IntArray, fine: IntArray, top: tuple[int, int, int]) -> dict[str, IntArray]:
    """Face groups of a box: the cell faces on each of its six planes (see :func:`box`)."""
    faces: dict[str, IntArray] = {}
    nvf = {"QUAD8": 4, "TRIA6": 3}[el.face_type]
    for name, alias, axis, end in BOX_FACES:
        level = top[axis] * end
        rows = []
        for f in el.faces:
            on = np.all(fine[:, f[:nvf], axis] == level, axis=1)
            rows.append(cells[on][:, f])
        faces[name] = np.concatenate(rows)
        if alias:
            faces[alias] = faces[name].copy()
    return faces


def _check_box_args(nx: int, ny: int, nz: int, x: tuple[float, float], y: tuple[float, float],
                    z: tuple[float, float], cell: str) -> None:
    where = "box"
    for name, n in (("nx", nx), ("ny", ny), ("nz", nz)):
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
            raise MeshError(f"{where}: {name} must be a positive integer (got {n!r})")
    for name, (a, b) in (("x", x), ("y", y), ("z", z)):
        if not (np.isfinite(a) and np.isfinite(b) and a < b):
            raise MeshError(f"{where}: {name} must be an interval (min, max) with "
                            f"min < max (got {(a, b)!r})")
    if cell not in BOX_CELLS:
        raise MeshError(f"{where}: cell must be one of {', '.join(BOX_CELLS)} (got {cell!r})")
