"""Convergence of the 3-D X-FEM geometry: volumes of both sides and the interface area
of a sphere and a tilted cylinder cutting the unit box, HEXA20 and TETRA10, N = 4, 8, 16.

    .venv/bin/python bench/xfem3d_geometry.py [HEXA20,TETRA10]

Prints per line: cell, shape, N, cut cells, interface edges left off LN = 0, cells with a
folded sub-tetrahedron, lifted edges, the errors of vol(-), vol(+), area, and the observed
orders against the previous N.  The shapes are the ones of tests/test_xfem3d.py.
"""
import math
import sys

import numpy as np

from xfemcontact.mesh import plex
from xfemcontact.mesh.generate import box
from xfemcontact.xfem import geometry3d

C = np.array([0.4689, 0.5311, 0.4693])
R = 0.3125
AXIS = np.array([0.1, 0.2, 1.0])


def cylinder(x):
    a = AXIS / np.linalg.norm(AXIS)
    dx = x - C
    return (dx ** 2).sum(axis=1) - (dx @ a) ** 2 - R ** 2


SHAPES = {"sphere": (lambda x: ((x - C) ** 2).sum(axis=1) - R ** 2, 4 / 3 * math.pi * R ** 3, 4 * math.pi * R ** 2),
          "cylinder": (cylinder, math.pi * R ** 2 * np.linalg.norm(AXIS), 2 * math.pi * R * np.linalg.norm(AXIS))}


def main(cells):
    for cell in cells:
        for name, (f, V, A) in SHAPES.items():
            prev = None
            for n in (4, 8, 16):
                mesh = plex.load(box(n, n, n, cell=cell))
                geo = geometry3d.build(mesh, f(mesh.x))
                vm, vp = geometry3d.volumes(mesh, geo)
                area = geometry3d.interface_area(mesh, geo)
                err = (abs(vm - V), abs(vp - (1 - V)), abs(area - A))
                orders = "" if prev is None else " ".join(f"{math.log2(p / q):5.2f}" for p, q in zip(prev, err))
                print(f"{cell:8s} {name:8s} {n:3d} {len(geo.cut_cells):5d} {geo.off_surface:3d} {geo.folded:4d} "
                      f"{geo.readjustment.lifted_edges:3d}  " + " ".join(f"{e:.2e}" for e in err) + "  " + orders,
                      flush=True)
                prev = err


if __name__ == "__main__":
    main(sys.argv[1].split(",") if len(sys.argv) > 1 else ["HEXA20", "TETRA10"])
