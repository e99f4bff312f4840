"""Shared by the mesh generators of this folder: a quadratic mesh of the square
[0, SIZE]^2 as a meshio.Mesh for Gmsh 2.2, with code_aster's SSNV509 group names."""
import meshio
import numpy as np

SIZE = 10.0
#: physical groups: the edges LIG1 (y = 0), LIG2 (x = SIZE), LIG3 (y = SIZE), LIG4 (x = 0), the surface SURF
GROUPS = {"LIG1": [1, 1], "LIG2": [2, 1], "LIG3": [3, 1], "LIG4": [4, 1], "SURF": [5, 2]}
CELL_TYPES = {3: "triangle6", 4: "quad8"}


def quadratic_square_mesh(vertices, cells):
    """Straight-sided quadratic cells from counter-clockwise vertex cells ``cells (n, 3|4)``
    on ``vertices (m, 2)``: mid-edge nodes at the edge midpoints, LINE3 boundary edges."""
    nv = cells.shape[1]
    edges = np.sort(np.concatenate([cells[:, [i, (i + 1) % nv]] for i in range(nv)]), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    mids = len(vertices) + inverse.reshape(nv, -1).T
    points = np.r_[vertices, vertices[unique].mean(axis=1)]
    quadratic = np.c_[cells, mids]
    # boundary edges: both ends on one side of the square
    lines, tags = [], []
    for tag, (axis, value) in enumerate([(1, 0.0), (0, SIZE), (1, SIZE), (0, 0.0)], start=1):
        on = np.all(np.abs(vertices[unique][:, :, axis] - value) < 1e-12, axis=1)
        lines.append(np.c_[unique[on], len(vertices) + np.nonzero(on)[0]])
        tags.append(np.full(on.sum(), tag))
    lines, tags = np.concatenate(lines), np.concatenate(tags)
    return meshio.Mesh(np.c_[points, np.zeros(len(points))], [("line3", lines), (CELL_TYPES[nv], quadratic)],
                       cell_data={"gmsh:physical": [tags, np.full(len(quadratic), 5)],
                                  "gmsh:geometrical": [tags, np.full(len(quadratic), 1)]},
                       field_data={k: np.array(v) for k, v in GROUPS.items()})
