"""Write ``ssnv509_jittered.msh``: an unstructured TRIA6 mesh of [0, 10]^2 (Gmsh 2.2).

A 21 x 21 grid whose interior points are moved at random by up to 0.15 m in x and y
(seeded), Delaunay-triangulated (800 triangles, straight-sided, mid-edge nodes at
the edge midpoints).  Physical groups: the edges LIG1 (y = 0), LIG2 (x = 10), LIG3
(y = 10), LIG4 (x = 0) and the surface SURF, code_aster's names for SSNV509.

    python cases/meshes/jittered_tria6.py    # from the checkout, with the venv's python
"""
import pathlib

import meshio
import numpy as np
from scipy.spatial import Delaunay

N, SIZE, JITTER, SEED = 21, 10.0, 0.15, 3


def jittered_tria6():
    rng = np.random.default_rng(SEED)
    t = np.linspace(0.0, SIZE, N)
    z = np.zeros(N - 1)
    boundary = np.r_[np.c_[t, np.zeros(N)], np.c_[z + SIZE, t[1:]], np.c_[t[::-1][1:], z + SIZE],
                     np.c_[z[1:], t[::-1][1:-1]]]
    inner = np.stack(np.meshgrid(t[1:-1], t[1:-1]), -1).reshape(-1, 2)
    inner += rng.uniform(-JITTER, JITTER, inner.shape)
    vertices = np.r_[boundary, inner]
    tri = Delaunay(vertices).simplices
    a, b, c = (vertices[tri[:, k]] for k in range(3))
    cw = np.cross(b - a, c - a) < 0
    tri[cw] = tri[cw][:, [0, 2, 1]]
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    mids = len(vertices) + inverse.reshape(3, -1).T
    points = np.r_[vertices, vertices[unique].mean(axis=1)]
    cells6 = np.c_[tri, mids]
    # boundary edges: both ends on one side of the square
    lines, tags = [], []
    for tag, (axis, value) in enumerate([(1, 0.0), (0, SIZE), (1, SIZE), (0, 0.0)], start=1):
        on = np.all(np.abs(vertices[unique][:, :, axis] - value) < 1e-12, axis=1)
        lines.append(np.c_[unique[on], len(vertices) + np.nonzero(on)[0]])
        tags.append(np.full(on.sum(), tag))
    lines, tags = np.concatenate(lines), np.concatenate(tags)
    names = {"LIG1": [1, 1], "LIG2": [2, 1], "LIG3": [3, 1], "LIG4": [4, 1], "SURF": [5, 2]}
    return meshio.Mesh(np.c_[points, np.zeros(len(points))], [("line3", lines), ("triangle6", cells6)],
                       cell_data={"gmsh:physical": [tags, np.full(len(cells6), 5)],
                                  "gmsh:geometrical": [tags, np.full(len(cells6), 1)]},
                       field_data={k: np.array(v) for k, v in names.items()})


if __name__ == "__main__":
    out = pathlib.Path(__file__).with_name("ssnv509_jittered.msh")
    meshio.write(out, jittered_tria6(), file_format="gmsh22", binary=False)
    print(f"wrote {out}")
