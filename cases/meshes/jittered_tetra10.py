"""Write ``jittered_tetra10.msh``: an unstructured TETRA10 mesh of [0, 1] x [0, 1] x [0, 2]
(Gmsh 2.2, ASCII), without Gmsh; and ``ssnv186e_jittered_tetra10.msh``, the same kind of
mesh of SSNV186E's block [0, 1] x [0, 20] x [0, 20] (``--ssnv186e``).

A 5 x 5 x 9 grid of points (SSNV186E: 3 x 13 x 13) whose interior points are moved at
random by up to 0.06 m (SSNV186E: 0.15 m) times the ratio of the grid step to the
smallest one in each direction, and whose boundary points are moved within their face
(edge points along their edge, corners fixed; seeded); Delaunay-tetrahedralised by
scipy (qhull), the flat tetrahedra qhull leaves on the faces of the box dropped;
straight edges, mid-edge nodes at the edge midpoints.  Physical groups: the volume
VOL, the TRIA6 faces left (x = 0), right (x = 1), front (y = 0), back (y = 1),
bottom (z = 0) and top (z = 2), the names of the box generator.

The cells are written in Gmsh's (VTK's) node order, which meshio's writer takes;
xfemcontact reads them back into code_aster's.

    python cases/meshes/jittered_tetra10.py              # from the checkout, with the venv's python
    python cases/meshes/jittered_tetra10.py --ssnv186e
    python cases/meshes/jittered_tetra10.py --cube 6     # also 10, 14: cube<N>_jittered_tetra10.msh
"""
import argparse
import pathlib

import meshio
import numpy as np
from scipy.spatial import Delaunay

#: (size (m), grid points, jitter (m), output file) of each mesh this writes
MESHES = {"default": ((1.0, 1.0, 2.0), (5, 5, 9), 0.06, "jittered_tetra10.msh"),
          "ssnv186e": ((1.0, 20.0, 20.0), (3, 13, 13), 0.15, "ssnv186e_jittered_tetra10.msh"),
          # the unit cube on N + 1 points a side, jittered by up to 0.3 of a step (the sphere of
          # cases/validation/sphere_stick_jittered_tetra10.toml under refinement)
          **{f"cube{n}": ((1.0, 1.0, 1.0), (n + 1,) * 3, 0.3 / n, f"cube{n}_jittered_tetra10.msh")
             for n in (6, 10, 14)}}
SEED = 7
FACES = (("left", 0, 0), ("right", 0, 1), ("front", 1, 0), ("back", 1, 1), ("bottom", 2, 0), ("top", 2, 1))
# our (code_aster's) tetrahedron: mid-edge nodes of 1-2, 2-3, 3-1, 1-4, 2-4, 3-4; the
# mirror image of VTK's, the same permutation both ways
EDGES = np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3], [2, 3]])
TO_VTK = np.array([0, 2, 1, 3, 6, 5, 4, 7, 9, 8])
FACE_NODES = np.array([[0, 1, 2, 4, 5, 6], [0, 3, 1, 7, 8, 4], [1, 3, 2, 8, 9, 5], [2, 3, 0, 9, 7, 6]])


def jittered_points(size, n, jitter):
    """``(n, 3)`` grid points, moved at random without leaving their face, edge or corner."""
    rng = np.random.default_rng(SEED)
    axes = [np.linspace(0.0, s, k) for s, k in zip(size, n)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    step = np.array([s / (k - 1) for s, k in zip(size, n)])
    on_side = np.isclose(grid, 0.0) | np.isclose(grid, size)
    move = rng.uniform(-jitter, jitter, grid.shape) * step / step.min()
    return grid + np.where(on_side, 0.0, move)


def tetra10(size=MESHES["default"][0], n=MESHES["default"][1], jitter=MESHES["default"][2]):
    """The meshio.Mesh of the module documentation: a box of ``size`` (m) on a jittered grid
    of ``n`` points."""
    vertices = jittered_points(size, n, jitter)
    tets = Delaunay(vertices).simplices
    a, b, c, d = (vertices[tets[:, k]] for k in range(4))
    signed = np.einsum("ki,ki->k", np.cross(b - a, c - a), d - a) / 6.0
    keep = np.abs(signed) > 1e-9 * np.prod(size) / len(tets)
    tets, signed = tets[keep], signed[keep]
    tets[signed > 0] = tets[signed > 0][:, [0, 2, 1, 3]]       # direct in code_aster's sense
    ends = np.sort(tets[:, EDGES].reshape(-1, 2), axis=1)
    edges, which = np.unique(ends, axis=0, return_inverse=True)
    mids = 0.5 * (vertices[edges[:, 0]] + vertices[edges[:, 1]])
    points = np.r_[vertices, mids]
    cells = np.c_[tets, len(vertices) + which.reshape(-1, 6)]
    blocks = [("tetra10", cells[:, TO_VTK])]
    physical, names = [np.ones(len(cells), int)], {"VOL": [1, 3]}
    faces = cells[:, FACE_NODES].reshape(-1, 6)
    for tag, (name, axis, end) in enumerate(FACES, start=2):
        plane = size[axis] * end
        on = np.all(np.isclose(points[faces[:, :3], axis], plane), axis=1)
        blocks.append(("triangle6", faces[on]))
        physical.append(np.full(int(on.sum()), tag))
        names[name] = [tag, 2]
    return meshio.Mesh(points, blocks, cell_data={"gmsh:physical": physical, "gmsh:geometrical": physical},
                       field_data=names)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ssnv186e", action="store_true", help="the mesh of SSNV186E's block")
    parser.add_argument("--cube", type=int, choices=(6, 10, 14), help="the unit cube on N + 1 points a side")
    args = parser.parse_args()
    size, n, jitter, name = MESHES["ssnv186e" if args.ssnv186e else f"cube{args.cube}" if args.cube else "default"]
    out = pathlib.Path(__file__).with_name(name)
    meshio.write(out, tetra10(size, n, jitter), file_format="gmsh22", binary=False)
    print(f"wrote {out}")
