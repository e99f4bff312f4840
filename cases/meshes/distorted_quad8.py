"""Write ``ssnv509_distorted.msh``: a distorted QUAD8 mesh of [0, 10]^2 (Gmsh 2.2).

A 20 x 20 grid of squares whose interior vertices are moved at random by up to a
quarter of the cell size in x and y (seeded): 400 straight-sided quadrangles that
are not parallelograms, so their isoparametric maps are not affine.  Mid-edge
nodes are at the edge midpoints.  Physical groups: the edges LIG1 (y = 0), LIG2
(x = 10), LIG3 (y = 10), LIG4 (x = 0) and the surface SURF, code_aster's names
for SSNV509.

    python cases/meshes/distorted_quad8.py    # from the checkout, with the venv's python
"""
import pathlib

import meshio
import numpy as np

N, SIZE, JITTER, SEED = 20, 10.0, 0.25, 7


def distorted_quad8(n=N, jitter=JITTER, seed=SEED):
    rng = np.random.default_rng(seed)
    h = SIZE / n
    t = np.linspace(0.0, SIZE, n + 1)
    P = np.stack(np.meshgrid(t, t, indexing="ij"), axis=-1)                 # P[i, j] = (x_i, y_j)
    P[1:-1, 1:-1] += rng.uniform(-jitter * h, jitter * h, P[1:-1, 1:-1].shape)
    vid = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    vertices = P.reshape(-1, 2)
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
    quads = np.stack([vid[i, j], vid[i + 1, j], vid[i + 1, j + 1], vid[i, j + 1]], axis=-1)
    edges = np.sort(np.concatenate([quads[:, [0, 1]], quads[:, [1, 2]], quads[:, [2, 3]], quads[:, [3, 0]]]), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    mids = len(vertices) + inverse.reshape(4, -1).T
    points = np.r_[vertices, vertices[unique].mean(axis=1)]
    cells8 = np.c_[quads, mids]
    lines, tags = [], []
    for tag, (axis, value) in enumerate([(1, 0.0), (0, SIZE), (1, SIZE), (0, 0.0)], start=1):
        on = np.all(np.abs(vertices[unique][:, :, axis] - value) < 1e-12, axis=1)
        lines.append(np.c_[unique[on], len(vertices) + np.nonzero(on)[0]])
        tags.append(np.full(on.sum(), tag))
    lines, tags = np.concatenate(lines), np.concatenate(tags)
    names = {"LIG1": [1, 1], "LIG2": [2, 1], "LIG3": [3, 1], "LIG4": [4, 1], "SURF": [5, 2]}
    return meshio.Mesh(np.c_[points, np.zeros(len(points))], [("line3", lines), ("quad8", cells8)],
                       cell_data={"gmsh:physical": [tags, np.full(len(cells8), 5)],
                                  "gmsh:geometrical": [tags, np.full(len(cells8), 1)]},
                       field_data={k: np.array(v) for k, v in names.items()})


if __name__ == "__main__":
    out = pathlib.Path(__file__).with_name("ssnv509_distorted.msh")
    meshio.write(out, distorted_quad8(), file_format="gmsh22", binary=False)
    print(f"wrote {out}")
