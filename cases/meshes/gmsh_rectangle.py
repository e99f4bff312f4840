"""Unstructured quadratic meshes of rectangles with Gmsh (TRIA6 and QUAD8), Gmsh 2.2 files.

    .venv/bin/pip install gmsh                      # once; the committed .msh files need no gmsh
    .venv/bin/python cases/meshes/gmsh_rectangle.py            # rewrite every mesh of MESHES
    .venv/bin/python cases/meshes/gmsh_rectangle.py --cell QUAD8 --x 0 2 --y 0 2 --h 0.2 \
        --seed 5 --out /tmp/q.msh                              # one mesh

TRIA6: Gmsh's Frontal-Delaunay triangulation.  QUAD8: the same, recombined into
quadrangles only (Blossom full-quad recombination, no subdivision), then made
second order with ``Mesh.SecondOrderIncomplete = 1`` (8-node serendipity
quadrangles, not quad9).  Mid-edge nodes sit at the edge midpoints (the boundary
is straight).  The mesh is made irregular, and reproducible, by a seeded size
field: the target edge length is ``h (1 + a sin(...))`` with random phases and
wave numbers drawn from ``numpy.random.default_rng(seed)``; ``Mesh.RandomSeed`` is
set too.  Physical groups, as in the case files' generated rectangles: edges
``bottom right top left`` and code_aster's ``LIG1 LIG2 LIG3 LIG4`` (the same edges),
the surface ``SURF`` and the corner points ``P1..P4`` ((x0, y0), (x1, y0), (x1, y1),
(x0, y1)).  A Gmsh 2.2 file writes an element once per physical group it belongs
to, so the boundary edges appear twice (once per name); groups are read by name.
"""
import argparse
import pathlib

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent

#: the committed meshes: file name -> arguments of :func:`mesh_rectangle`
MESHES = {
    # the straight-interface campaign: 2 m x 2 m plates, about 10 x 10 cells
    "gmsh_tria6_2x2.msh": dict(cell="TRIA6", x=(0.0, 2.0), y=(0.0, 2.0), h=0.2, seed=11),
    "gmsh_quad8_2x2.msh": dict(cell="QUAD8", x=(0.0, 2.0), y=(0.0, 2.0), h=0.2, seed=12),
    # a non-square plate, coarser QUAD8 (about 12 x 8 cells)
    "gmsh_quad8_3x2.msh": dict(cell="QUAD8", x=(0.0, 3.0), y=(0.0, 2.0), h=0.25, seed=13),
    # SSNV509's 10 m square for the curved interfaces, about 20 x 20 cells
    "gmsh_tria6_10x10.msh": dict(cell="TRIA6", x=(0.0, 10.0), y=(0.0, 10.0), h=0.5, seed=21),
    "gmsh_quad8_10x10.msh": dict(cell="QUAD8", x=(0.0, 10.0), y=(0.0, 10.0), h=0.5, seed=22),
}

EDGES = ("bottom", "right", "top", "left")


def mesh_rectangle(path, cell="TRIA6", x=(0.0, 2.0), y=(0.0, 2.0), h=0.2, seed=0,
                   amplitude=0.3):
    """Write an unstructured ``cell`` mesh of ``[x0, x1] x [y0, y1]`` (target edge ``h``) to ``path``."""
    import gmsh

    rng = np.random.default_rng(seed)
    (x0, x1), (y0, y1) = x, y
    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.model.add("rectangle")
        geo = gmsh.model.geo
        pts = [geo.addPoint(px, py, 0.0, h) for px, py in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))]
        lines = [geo.addLine(pts[k], pts[(k + 1) % 4]) for k in range(4)]
        loop = geo.addCurveLoop(lines)
        surf = geo.addPlaneSurface([loop])
        geo.synchronize()
        for k, name in enumerate(EDGES):
            gmsh.model.addPhysicalGroup(1, [lines[k]], name=name)
            gmsh.model.addPhysicalGroup(1, [lines[k]], name=f"LIG{k + 1}")
        gmsh.model.addPhysicalGroup(2, [surf], name="SURF")
        for k, p in enumerate(pts):
            gmsh.model.addPhysicalGroup(0, [p], name=f"P{k + 1}")
        # seeded, smoothly varying target size: an irregular but graded mesh
        kx, ky = rng.uniform(1.0, 3.0, 2) * 2 * np.pi / max(x1 - x0, y1 - y0)
        px, py = rng.uniform(0.0, 2 * np.pi, 2)
        field = gmsh.model.mesh.field.add("MathEval")
        gmsh.model.mesh.field.setString(
            field, "F", f"{h!r}*(1 + {amplitude!r}*sin({kx!r}*x + {px!r})*sin({ky!r}*y + {py!r}))")
        gmsh.model.mesh.field.setAsBackgroundMesh(field)
        for name, value in (("Mesh.MeshSizeExtendFromBoundary", 0), ("Mesh.MeshSizeFromPoints", 0),
                            ("Mesh.MeshSizeFromCurvature", 0), ("Mesh.Algorithm", 6),
                            ("Mesh.RandomSeed", int(seed)), ("Mesh.Smoothing", 5),
                            ("Mesh.ElementOrder", 2), ("Mesh.SecondOrderIncomplete", 1),
                            ("Mesh.SecondOrderLinear", 1),
                            ("Mesh.MshFileVersion", 2.2), ("Mesh.Binary", 0), ("Mesh.SaveAll", 0)):
            gmsh.option.setNumber(name, value)
        if cell == "QUAD8":
            for name, value in (("Mesh.Algorithm", 8), ("Mesh.RecombineAll", 1),
                                ("Mesh.RecombinationAlgorithm", 3), ("Mesh.SubdivisionAlgorithm", 0)):
                gmsh.option.setNumber(name, value)
        elif cell != "TRIA6":
            raise ValueError(f"cell must be TRIA6 or QUAD8, not {cell!r}")
        gmsh.model.mesh.generate(2)
        types = set(gmsh.model.mesh.getElementTypes(2))
        want = {"TRIA6": 9, "QUAD8": 16}[cell]          # Gmsh element types: 9 triangle6, 16 quad8
        if types != {want}:
            raise RuntimeError(f"{path}: Gmsh made 2-D element types {sorted(types)}, wanted only {want}")
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def summary(path):
    """Cell type, number of cells and mean vertex-edge length, as xfemcontact reads the file."""
    from xfemcontact.mesh.read import read_mesh

    m = read_mesh(path)
    nv = m.n_vertices_per_cell
    v = m.cells[:, :nv]
    edges = np.unique(np.sort(np.concatenate([v[:, [k, (k + 1) % nv]] for k in range(nv)]), axis=1), axis=0)
    lengths = np.linalg.norm(m.points[edges[:, 0]] - m.points[edges[:, 1]], axis=1)
    groups = sorted(set(m.edge_groups) | set(m.cell_groups) | set(m.node_groups))
    return (f"{m.cell_type}, {len(m.cells)} cells, {len(m.points)} nodes, mean edge "
            f"{lengths.mean():.4g} m (min {lengths.min():.3g}, max {lengths.max():.3g}); groups {groups}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cell", choices=("TRIA6", "QUAD8"))
    ap.add_argument("--x", type=float, nargs=2, default=(0.0, 2.0))
    ap.add_argument("--y", type=float, nargs=2, default=(0.0, 2.0))
    ap.add_argument("--h", type=float, default=0.2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=pathlib.Path)
    args = ap.parse_args(argv)
    if args.cell:
        out = args.out or pathlib.Path(f"gmsh_{args.cell.lower()}.msh")
        mesh_rectangle(out, args.cell, tuple(args.x), tuple(args.y), args.h, args.seed)
        print(f"wrote {out}: {summary(out)}")
        return
    for name, kw in MESHES.items():
        mesh_rectangle(HERE / name, **kw)
        print(f"wrote {HERE / name}: {summary(HERE / name)}")


if __name__ == "__main__":
    main()
