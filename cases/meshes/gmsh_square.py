"""Write ``gmsh_tria6.msh`` and ``gmsh_quad8.msh``: unstructured quadratic meshes of
[0, 10]^2 made by Gmsh (Gmsh 2.2 files, h = 0.5 m).

TRIA6: Gmsh's default 2-D mesher (940 triangles, 1961 nodes).  QUAD8: its triangles
recombined into 462 quadrangles (none a parallelogram), second order incomplete.
Gmsh places the mid-edge nodes by its own arithmetic, up to 3e-13 m off the edge
middles: along an edge the quadratic interpolant of a straight level set is then a
line only up to round-off, which is what the cases on these meshes exercise
(tractions on edges the interface crosses, ``cases/validation/cut_edge_*.toml``).
Physical groups: the edges LIG1 (y = 0), LIG2 (x = 10), LIG3 (y = 10), LIG4
(x = 0), the corners P1 (0, 0), P2 (10, 0), P3 (10, 10), P4 (0, 10) and the
surface SURF.

Needs the ``gmsh`` Python package (``.venv/bin/pip install gmsh``); the meshes are in
the repository, so the tests do not.

    .venv/bin/python cases/meshes/gmsh_square.py
"""
import pathlib

import gmsh

SIZE, H = 10.0, 0.5


def write(path, quad):
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(path.stem)
        geo = gmsh.model.geo
        corners = [geo.addPoint(x, y, 0.0, H) for x, y in [(0, 0), (SIZE, 0), (SIZE, SIZE), (0, SIZE)]]
        lines = [geo.addLine(corners[i], corners[(i + 1) % 4]) for i in range(4)]
        surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.synchronize()
        for i, line in enumerate(lines):
            gmsh.model.addPhysicalGroup(1, [line], i + 1, f"LIG{i + 1}")
        for i, point in enumerate(corners):
            gmsh.model.addPhysicalGroup(0, [point], 10 + i, f"P{i + 1}")
        gmsh.model.addPhysicalGroup(2, [surface], 5, "SURF")
        if quad:
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
            gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 1)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", 2.2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    print(f"wrote {path}")


if __name__ == "__main__":
    here = pathlib.Path(__file__).parent
    write(here / "gmsh_tria6.msh", quad=False)
    write(here / "gmsh_quad8.msh", quad=True)
