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

from square import SIZE, quadratic_square_mesh

N, JITTER, SEED = 21, 0.15, 3


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
    return quadratic_square_mesh(vertices, tri)


if __name__ == "__main__":
    out = pathlib.Path(__file__).with_name("ssnv509_jittered.msh")
    meshio.write(out, jittered_tria6(), file_format="gmsh22", binary=False)
    print(f"wrote {out}")
