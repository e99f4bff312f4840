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

from square import SIZE, quadratic_square_mesh

N, JITTER, SEED = 20, 0.25, 7


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
    return quadratic_square_mesh(vertices, quads)


if __name__ == "__main__":
    out = pathlib.Path(__file__).with_name("ssnv509_distorted.msh")
    meshio.write(out, distorted_quad8(), file_format="gmsh22", binary=False)
    print(f"wrote {out}")
