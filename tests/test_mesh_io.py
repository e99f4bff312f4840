"""Mesh reading (MED, Gmsh, XDMF, VTU), the rectangle generator and uniform refinement."""

import meshio
import numpy as np
import pytest

from xfemcontact.errors import MeshError
from xfemcontact.fem.elements import Seg3, element
from xfemcontact.mesh.generate import rectangle
from xfemcontact.mesh.raw import RawMesh
from xfemcontact.mesh.read import from_meshio, read_mesh
from xfemcontact.mesh.refine import _child_table, refine_uniform
from conftest import SHARED_MESHES

MESHES = SHARED_MESHES
SSNV509 = {"ssnv509a": ("QUAD8", 1600, 4961, 40), "ssnv509b": ("TRIA6", 800, 1681, 20)}
SIDES = {"LIG1": (1, 0.0), "LIG2": (0, 10.0), "LIG3": (1, 10.0), "LIG4": (0, 0.0)}
CORNERS = {"P1": (0, 0), "P2": (10, 0), "P3": (10, 10), "P4": (0, 10)}
MESHIO_TYPE = {"QUAD8": "quad8", "TRIA6": "triangle6"}

needs_med = pytest.mark.skipif(not (MESHES / "ssnv509a.mmed").exists(),
                               reason="code_aster meshes not available")


# -- helpers -------------------------------------------------------------------------
def cell_areas(mesh):
    """Exact areas (m^2) of the isoparametric cells, by Gauss quadrature."""
    ref = element(mesh.cell_type)
    xi, w = ref.quadrature(4)
    return ref.jacobian_dets(mesh.points[mesh.cells], xi) @ w


def vertex_signed_areas(mesh):
    v = mesh.points[mesh.cells[:, : mesh.n_vertices_per_cell]]
    w = np.roll(v, -1, axis=1)
    return 0.5 * np.sum(v[..., 0] * w[..., 1] - w[..., 0] * v[..., 1], axis=1)


def sorted_centroids(mesh):
    c = np.round(mesh.points[mesh.cells].mean(axis=1), 9)
    return c[np.lexsort(c.T[::-1])]


def assert_one_line(exc, *parts):
    msg = str(exc.value)
    assert "\n" not in msg
    for p in parts:
        assert p in msg, msg


def to_meshio(mesh, **kw):
    """meshio.Mesh of a RawMesh: cell block, its edges of LIG1 and LIG3, corner P1."""
    cells = [(MESHIO_TYPE[mesh.cell_type], mesh.cells),
             ("line3", np.concatenate([mesh.edge_groups["LIG1"], mesh.edge_groups["LIG3"]])),
             ("vertex", mesh.node_groups["P1"][:, None])]
    return meshio.Mesh(mesh.points, cells, **kw)


# -- MED -----------------------------------------------------------------------------
@needs_med
@pytest.mark.parametrize("name", sorted(SSNV509))
def test_med_mesh(name):
    cell_type, n_cells, n_nodes, n_side = SSNV509[name]
    m = read_mesh(MESHES / f"{name}.mmed", display_name=f"{name}.mmed")
    assert m.source == f"{name}.mmed"
    assert (m.cell_type, m.cells.shape, m.points.shape) == (
        cell_type, (n_cells, element(cell_type).nn), (n_nodes, 2))
    assert m.group_names() == sorted(["LIG1", "LIG2", "LIG3", "LIG4", "SURF", "MAILLE",
                                      "P1", "P2", "P3", "P4", "N141"])
    for g in ("SURF", "MAILLE"):
        np.testing.assert_array_equal(m.cell_groups[g], np.arange(n_cells))
    for g, (axis, value) in SIDES.items():
        assert m.edge_groups[g].shape == (n_side, 3)
        np.testing.assert_allclose(m.points[m.group_nodes(g), axis], value)
        assert len(m.group_nodes(g)) == 2 * n_side + 1
    for g, xy in CORNERS.items():
        np.testing.assert_allclose(m.points[m.node_groups[g]], [xy])
    np.testing.assert_allclose(m.points[m.node_groups["N141"]], [(0, 5)])
    assert np.all(vertex_signed_areas(m) > 0)
    assert np.all(cell_areas(m) > 0)
    assert cell_areas(m).sum() == pytest.approx(100.0, rel=1e-12)


# -- Gmsh, XDMF, VTU -------------------------------------------------------------------
@pytest.mark.parametrize("cell", ["QUAD8", "TRIA6"])
def test_gmsh22_round_trip(tmp_path, cell):
    g = rectangle(3, 2, cell=cell)
    nc = len(g.cells)
    physical = [np.where(np.arange(nc) < nc // 2, 1, 2), np.repeat([3, 4], 3), np.array([5])]
    dims = {"lower": (1, 2), "upper": (2, 2), "LIG1": (3, 1), "LIG3": (4, 1), "P1": (5, 0)}
    mesh = to_meshio(g, cell_data={"gmsh:physical": physical, "gmsh:geometrical": physical},
                     field_data={k: np.array(v) for k, v in dims.items()})
    meshio.write(tmp_path / "m.msh", mesh, file_format="gmsh22", binary=False)
    m = read_mesh(tmp_path / "m.msh")
    assert m.cell_type == cell
    np.testing.assert_allclose(m.points, g.points)
    np.testing.assert_array_equal(m.cells, g.cells)
    np.testing.assert_array_equal(m.cell_groups["lower"], np.arange(nc // 2))
    np.testing.assert_array_equal(m.cell_groups["upper"], np.arange(nc // 2, nc))
    for name in ("LIG1", "LIG3"):
        np.testing.assert_array_equal(m.edge_groups[name], g.edge_groups[name])
    np.testing.assert_array_equal(m.node_groups["P1"], g.node_groups["P1"])


GMSH41 = """$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
4
0 4 "corner"
1 3 "bottom"
2 1 "domain"
2 2 "SURF"
$EndPhysicalNames
$Entities
1 1 1 0
1 0 0 0 1 4
1 0 0 0 1 0 0 1 3 2 1 -1
1 0 0 0 1 1 0 2 1 2 1 1
$EndEntities
$Nodes
1 9 1 9
2 1 0 9
1
2
3
4
5
6
7
8
9
0 0 0
0.5 0 0
1 0 0
0 0.5 0
0.5 0.5 0
1 0.5 0
0 1 0
0.5 1 0
1 1 0
$EndNodes
$Elements
3 4 1 4
0 1 15 1
1 1
1 1 8 1
2 1 3 2
2 1 9 2
3 1 3 9 2 6 5
4 1 9 7 5 8 4
$EndElements
"""


def test_gmsh41_surface_in_two_physical_groups(tmp_path):
    (tmp_path / "m.msh").write_text(GMSH41)
    m = read_mesh(tmp_path / "m.msh")
    assert m.cell_type == "TRIA6" and m.cells.shape == (2, 6)
    for g in ("domain", "SURF"):
        np.testing.assert_array_equal(m.cell_groups[g], [0, 1])
    np.testing.assert_array_equal(m.edge_groups["bottom"], [[0, 2, 1]])
    np.testing.assert_array_equal(m.node_groups["corner"], [0])
    assert cell_areas(m).sum() == pytest.approx(1.0)


def test_vtu_round_trip_with_cell_sets(tmp_path):
    g = rectangle(2, 2, cell="TRIA6")
    none = np.array([], int)
    sets = {"SURF": [np.arange(len(g.cells)), none, none],
            "LIG1": [none, np.arange(2), none], "LIG3": [none, np.arange(2, 4), none],
            "P1": [none, none, np.array([0])]}
    meshio.write(tmp_path / "m.vtu", to_meshio(g, cell_sets=sets))
    m = read_mesh(tmp_path / "m.vtu")
    np.testing.assert_allclose(m.points, g.points)
    np.testing.assert_array_equal(m.cells, g.cells)
    np.testing.assert_array_equal(m.cell_groups["SURF"], g.cell_groups["SURF"])
    for name in ("LIG1", "LIG3"):
        np.testing.assert_array_equal(m.edge_groups[name], g.edge_groups[name])
    np.testing.assert_array_equal(m.node_groups["P1"], g.node_groups["P1"])


def test_xdmf_round_trip_with_cell_sets(tmp_path):
    # meshio 5.0 writes XDMF without sets and cannot read back a "Mixed"
    # topology of quadratic cells: one cell block, sets as integer cell data
    g = rectangle(2, 2, cell="QUAD8")
    mesh = meshio.Mesh(g.points, [("quad8", g.cells)],
                       cell_sets={"lower": [np.array([0, 1])], "upper": [np.array([2, 3])]})
    mesh.cell_sets_to_data()
    meshio.write(tmp_path / "m.xdmf", mesh)
    m = read_mesh(tmp_path / "m.xdmf")
    np.testing.assert_allclose(m.points, g.points)
    np.testing.assert_array_equal(m.cells, g.cells)
    np.testing.assert_array_equal(m.cell_groups["lower"], [0, 1])
    np.testing.assert_array_equal(m.cell_groups["upper"], [2, 3])


def test_xdmf_mixed_quadratic_is_a_clear_error(tmp_path):
    meshio.write(tmp_path / "m.xdmf", to_meshio(rectangle(1, 1)))
    with pytest.raises(MeshError) as exc:
        read_mesh(tmp_path / "m.xdmf")
    assert_one_line(exc, "m.xdmf: cannot read as XDMF", "Mixed")


def test_meshio_sets_are_groups():
    g = rectangle(2, 1)
    none = np.array([], int)
    mesh = to_meshio(g, cell_sets={"left": [np.array([0]), none, none],
                                   "LIG1": [none, np.arange(2), none]},
                     point_sets={"corners": np.array([0, 4])})
    m = from_meshio(mesh, "sets")
    np.testing.assert_array_equal(m.cell_groups["left"], [0])
    np.testing.assert_array_equal(m.edge_groups["LIG1"], g.edge_groups["LIG1"])
    np.testing.assert_array_equal(m.node_groups["corners"], [0, 4])


def test_med_group_in_several_families():
    g = rectangle(2, 1)
    mesh = to_meshio(g, cell_data={"cell_tags": [np.array([-1, -2]), np.array([-3, 0, 0, 0]),
                                                 np.array([0])]},
                     point_data={"point_tags": np.where(np.arange(len(g.points)) == 4, 1, 0)})
    mesh.cell_tags = {-1: ["A"], -2: ["A", "B"], -3: ["EDGE"]}
    mesh.point_tags = {1: ["P2"]}
    m = from_meshio(mesh, "families.med", "med")
    np.testing.assert_array_equal(m.cell_groups["A"], [0, 1])
    np.testing.assert_array_equal(m.cell_groups["B"], [1])
    np.testing.assert_array_equal(m.edge_groups["EDGE"], g.edge_groups["LIG1"][:1])
    np.testing.assert_array_equal(m.node_groups["P2"], [4])
    assert "P1" not in m.node_groups                        # family 0: no group


def test_several_blocks_are_concatenated():
    g = rectangle(2, 2, cell="TRIA6")
    none = np.array([], int)
    mesh = meshio.Mesh(g.points, [("triangle6", g.cells[:3]), ("vertex", np.array([[0]])),
                                  ("triangle6", g.cells[3:])],
                       cell_sets={"B": [none, none, np.array([0, 1])]})
    m = from_meshio(mesh, "blocks")
    np.testing.assert_array_equal(m.cells, g.cells)
    np.testing.assert_array_equal(m.cell_groups["B"], [3, 4])


def test_unused_nodes_keep_numbering():
    g = rectangle(1, 1)
    points = np.r_[[[5.0, 5.0]], g.points]                 # node 0 used by no cell
    m = from_meshio(meshio.Mesh(points, [("quad8", g.cells + 1)]), "unused")
    np.testing.assert_array_equal(m.cells, g.cells + 1)
    np.testing.assert_allclose(m.points, points)


# -- errors --------------------------------------------------------------------------
def test_missing_file(tmp_path):
    with pytest.raises(MeshError) as exc:
        read_mesh(tmp_path / "nope.med", display_name="nope.med")
    assert_one_line(exc, "nope.med: mesh file not found")


def test_unknown_extension(tmp_path):
    (tmp_path / "m.stl").write_text("solid\n")
    with pytest.raises(MeshError) as exc:
        read_mesh(tmp_path / "m.stl", display_name="m.stl")
    assert_one_line(exc, "m.stl: unknown mesh format '.stl'", ".med", ".mmed", ".msh",
                    ".xdmf", ".vtu")


def test_unreadable_file(tmp_path):
    (tmp_path / "m.msh").write_text("this is not a mesh\n")
    with pytest.raises(MeshError) as exc:
        read_mesh(tmp_path / "m.msh", display_name="m.msh")
    assert_one_line(exc, "m.msh: cannot read as Gmsh")


@pytest.mark.parametrize("kind, n, hint", [
    ("triangle", 3, "Gmsh -order 2, Salome 'quadratic mesh'"),
    ("quad", 4, "Gmsh -order 2, Salome 'quadratic mesh'"),
    ("quad9", 9, "Mesh.SecondOrderIncomplete=1")])
def test_unsupported_2d_cells(tmp_path, kind, n, hint):
    points = np.random.default_rng(0).random((9, 2))
    meshio.write(tmp_path / "m.vtu", meshio.Mesh(points, [(kind, np.arange(n)[None])]))
    with pytest.raises(MeshError) as exc:
        read_mesh(tmp_path / "m.vtu", display_name="m.vtu")
    assert_one_line(exc, f"m.vtu: unsupported 2-D cells {kind} x1", "quad8 (QUAD8)",
                    "triangle6 (TRIA6)", hint)


def test_mixed_quadratic_cells():
    g, t = rectangle(1, 1), rectangle(1, 1, cell="TRIA6")
    mesh = meshio.Mesh(t.points, [("quad8", g.cells), ("triangle6", t.cells)])
    with pytest.raises(MeshError) as exc:
        from_meshio(mesh, "mixed.med")
    assert_one_line(exc, "mixed.med: unsupported 2-D cells quad8 x1, triangle6 x2",
                    "one cell type per mesh")


def test_no_2d_cells_and_3d_cells():
    points = np.random.default_rng(0).random((10, 3))
    with pytest.raises(MeshError) as exc:
        from_meshio(meshio.Mesh(points[:, :2], [("line3", np.array([[0, 1, 2]]))]), "lines")
    assert_one_line(exc, "lines: no 2-D cells (found: line3 x1)")
    with pytest.raises(MeshError) as exc:                 # 3-D cells: quadratic ones only
        from_meshio(meshio.Mesh(points, [("tetra", np.arange(4)[None])]), "tet")
    assert_one_line(exc, "tet: unsupported 3-D cells tetra x1", "Gmsh -order 2")
    g = rectangle(1, 1)
    linear = meshio.Mesh(g.points, [("quad", g.cells[:, :4]), ("line", g.cells[:, :2])])
    with pytest.raises(MeshError) as exc:                 # the 2-D cells are reported
        from_meshio(linear, "linear")
    assert_one_line(exc, "linear: unsupported 2-D cells quad x1", "Gmsh -order 2")
    seg2 = meshio.Mesh(g.points, [("quad8", g.cells), ("line", g.cells[:, :2])])
    with pytest.raises(MeshError) as exc:
        from_meshio(seg2, "seg2")
    assert_one_line(exc, "seg2: unsupported cells line x1", "line3")


def test_group_outside_the_mesh_and_non_planar():
    g = rectangle(1, 1)
    bad = meshio.Mesh(g.points, [("quad8", g.cells), ("vertex", np.array([[99]]))],
                      cell_sets={"P": [np.array([], int), np.array([0])]})
    with pytest.raises(MeshError) as exc:
        from_meshio(bad, "bad")
    assert_one_line(exc, "bad: node group P refers to node 99", "has 8 nodes")
    tilted = np.c_[g.points, g.points[:, 0]]
    with pytest.raises(MeshError) as exc:
        from_meshio(meshio.Mesh(tilted, [("quad8", g.cells)]), "tilted")
    assert_one_line(exc, "tilted: mesh is not planar")


# -- generator ------------------------------------------------------------------------
@pytest.mark.parametrize("cell, n_cells", [("QUAD8", 12), ("TRIA6", 24)])
def test_rectangle_counts_areas_groups(cell, n_cells):
    nx, ny, x, y = 4, 3, (-1.0, 3.0), (2.0, 3.5)
    n_nodes = (2 * nx + 1) * (2 * ny + 1) - (nx * ny if cell == "QUAD8" else 0)
    m = rectangle(nx, ny, x=x, y=y, cell=cell)
    assert m.cells.shape == (n_cells, element(cell).nn) and m.points.shape == (n_nodes, 2)
    assert len(np.unique(m.cells)) == n_nodes
    np.testing.assert_allclose(cell_areas(m), 6.0 / n_cells)
    assert np.all(vertex_signed_areas(m) > 0)
    for names, axis, value, n in (("LIG1 bottom", 1, y[0], nx), ("LIG2 right", 0, x[1], ny),
                                  ("LIG3 top", 1, y[1], nx), ("LIG4 left", 0, x[0], ny)):
        a, b = names.split()
        np.testing.assert_array_equal(m.edge_groups[a], m.edge_groups[b])
        e = m.points[m.edge_groups[a]]                          # (n, 3, 2)
        assert e.shape == (n, 3, 2)
        np.testing.assert_allclose(e[..., axis], value)
        np.testing.assert_allclose(e[:, 2], (e[:, 0] + e[:, 1]) / 2)
    np.testing.assert_array_equal(m.cell_groups["SURF"], np.arange(n_cells))
    corners = [(x[0], y[0]), (x[1], y[0]), (x[1], y[1]), (x[0], y[1])]
    for k, xy in enumerate(corners):
        np.testing.assert_allclose(m.points[m.node_groups[f"P{k + 1}"]], [xy])
    assert m.check() is m


@needs_med
def test_rectangle_reproduces_code_aster_meshes():
    b = read_mesh(MESHES / "ssnv509b.mmed")
    np.testing.assert_allclose(sorted_centroids(rectangle(20, 20, cell="TRIA6")),
                               sorted_centroids(b), atol=1e-9)
    for d in ("right", "left"):
        other = sorted_centroids(rectangle(20, 20, cell="TRIA6", diagonal=d))
        assert not np.allclose(other, sorted_centroids(b))
    a = read_mesh(MESHES / "ssnv509a.mmed")
    np.testing.assert_allclose(sorted_centroids(rectangle(40, 40)), sorted_centroids(a),
                               atol=1e-9)


@pytest.mark.parametrize("diagonal, slope", [("right", 1), ("left", -1)])
def test_rectangle_diagonals(diagonal, slope):
    m = rectangle(2, 1, x=(0, 2), y=(0, 1), cell="TRIA6", diagonal=diagonal)
    v = m.points[m.cells[:, :3]]
    # the edge shared by the two triangles of each square is the diagonal
    for sq in range(2):
        a, b = (set(map(tuple, v[2 * sq + k])) for k in range(2))
        (p, q) = sorted(a & b)
        assert (q[1] - p[1]) / (q[0] - p[0]) == slope


def test_clockwise_input_is_reoriented():
    for cell in ("QUAD8", "TRIA6"):
        m = rectangle(3, 3, cell=cell)
        ccw = m.cells.copy()
        m.cells = m.cells[:, element(cell).reverse]
        assert np.all(vertex_signed_areas(m) < 0)
        m.check()
        assert np.all(vertex_signed_areas(m) > 0)
        np.testing.assert_array_equal(np.sort(m.cells, axis=1), np.sort(ccw, axis=1))
        np.testing.assert_allclose(cell_areas(m).sum(), 100.0)


def test_rectangle_bad_arguments():
    for kw, part in (({"nx": 0, "ny": 1}, "nx must be a positive integer"),
                     ({"nx": 1, "ny": 1, "x": (1.0, 0.0)}, "x must be an interval"),
                     ({"nx": 1, "ny": 1, "cell": "TRIA3"}, "cell must be one of"),
                     ({"nx": 1, "ny": 1, "diagonal": "up"}, "diagonal must be one of")):
        with pytest.raises(MeshError) as exc:
            rectangle(**kw)
        assert_one_line(exc, "rectangle: " + part)


def test_rectangle_640():
    for cell, n in (("QUAD8", 640 * 640), ("TRIA6", 2 * 640 * 640)):
        m = rectangle(640, 640, cell=cell)
        assert len(m.cells) == n


# -- refinement -----------------------------------------------------------------------
def distinct_points(points):
    return len(np.unique(np.round(points, 10), axis=0))


@pytest.mark.parametrize("cell", ["QUAD8", "TRIA6"])
def test_refine_counts_area_nodes(cell):
    m = rectangle(3, 2, x=(0, 3), y=(0, 1), cell=cell)
    n_edges = len(np.unique(np.sort(m.cells[:, element(cell).edges][..., :2], -1)
                            .reshape(-1, 2), axis=0))
    inner = 5 if cell == "QUAD8" else 3
    r = refine_uniform(m)
    assert r.cells.shape == (4 * len(m.cells), m.cells.shape[1])
    assert len(r.points) == len(m.points) + 2 * n_edges + inner * len(m.cells)
    assert distinct_points(r.points) == len(r.points)       # no duplicated node
    assert len(np.unique(r.cells)) == len(r.points)         # no unused node
    np.testing.assert_array_equal(r.points[: len(m.points)], m.points)
    np.testing.assert_allclose(cell_areas(r), np.repeat(cell_areas(m), 4) / 4)
    assert np.all(vertex_signed_areas(r) > 0)
    assert r.check() is r
    r2 = refine_uniform(m, levels=2)
    assert len(r2.cells) == 16 * len(m.cells)
    assert distinct_points(r2.points) == len(r2.points)
    assert refine_uniform(m, levels=0) is m
    with pytest.raises(MeshError) as exc:
        refine_uniform(m, levels=1.5)
    assert_one_line(exc, "refine_uniform: levels must be a non-negative integer")


def test_refine_quad8_rectangle_is_the_finer_rectangle():
    r = refine_uniform(rectangle(3, 2))
    f = rectangle(6, 4)
    assert len(r.points) == len(f.points)
    np.testing.assert_allclose(sorted_centroids(r), sorted_centroids(f), atol=1e-9)


@pytest.mark.parametrize("cell", ["QUAD8", "TRIA6"])
def test_refine_groups(cell):
    m = rectangle(3, 2, cell=cell)
    m.cell_groups["some"] = np.array([0, 4])
    r = refine_uniform(m)
    for name, edges in m.edge_groups.items():
        e = r.edge_groups[name]
        assert e.shape == (2 * len(edges), 3)
        assert set(np.unique(e)) >= set(np.unique(edges))
    np.testing.assert_allclose(r.points[r.edge_groups["LIG1"]][..., 1], 0.0)
    np.testing.assert_allclose(r.points[r.group_nodes("LIG2")][:, 0], 10.0)
    # group edges are edges of the refined cells (same nodes, no duplicates)
    cell_edges = {tuple(sorted(e)) for e in r.cells[:, element(cell).edges].reshape(-1, 3)
                  .tolist()}
    assert all(tuple(sorted(e)) in cell_edges for e in r.edge_groups["LIG1"].tolist())
    np.testing.assert_array_equal(r.cell_groups["SURF"], np.arange(len(r.cells)))
    np.testing.assert_array_equal(r.cell_groups["some"], [0, 1, 2, 3, 16, 17, 18, 19])
    for k in range(4):
        np.testing.assert_array_equal(r.node_groups[f"P{k + 1}"], m.node_groups[f"P{k + 1}"])


@needs_med
def test_refine_ssnv509b_like_code_aster():
    b = read_mesh(MESHES / "ssnv509b.mmed")
    r = refine_uniform(b)
    assert (len(r.cells), len(r.points)) == (3200, 6561)
    assert distinct_points(r.points) == 6561
    assert cell_areas(r).sum() == pytest.approx(100.0, rel=1e-12)
    assert r.edge_groups["LIG1"].shape == (40, 3)
    np.testing.assert_allclose(r.points[r.group_nodes("LIG1")][:, 1], 0.0)
    np.testing.assert_allclose(r.points[r.node_groups["N141"]], [(0, 5)])
    r.check()


@pytest.mark.parametrize("cell", ["QUAD8", "TRIA6"])
def test_refine_curved_cells_follow_parent_map(cell):
    m = rectangle(2, 2, x=(0, 1), y=(0, 1), cell=cell)
    mids = np.unique(m.cells[:, element(cell).nv:])
    rng = np.random.default_rng(1)
    m.points = m.points.copy()
    m.points[mids] += 0.02 * rng.standard_normal((len(mids), 2))   # curved edges
    m.check()
    r = refine_uniform(m)
    ref, child_xi = element(cell), _child_table(cell)["child_xi"]    # (4, nn, 2)
    expected = np.einsum("cij,pjx->pcix", ref.shape(child_xi), m.points[m.cells])
    np.testing.assert_allclose(r.points[r.cells].reshape(expected.shape), expected,
                               atol=1e-14)
    # the bottom edge group: new mid-nodes on the parent's quadratic curve
    e = m.edge_groups["LIG1"]
    seg = Seg3.shape(np.array([-0.5, 0.5]))
    on_curve = np.einsum("sn,enx->esx", seg, m.points[e])      # (edges, 2, 2)
    np.testing.assert_allclose(r.points[r.edge_groups["LIG1"][:, 2]].reshape(-1, 2, 2),
                               on_curve, atol=1e-14)
    assert np.abs(on_curve[..., 1]).max() > 1e-3              # really off the chord
    assert cell_areas(r).sum() == pytest.approx(cell_areas(m).sum(), rel=1e-12)


def test_refine_edge_group_that_is_no_cell_edge():
    m = rectangle(1, 1, x=(0, 1), y=(0, 1))
    m.points = np.r_[m.points, [[0.5, 0.55]]]                 # an extra node
    m.edge_groups = {"crack": np.array([[3, 4, 8]])}          # (0,.5)-(1,.5) via (.5,.55)
    r = refine_uniform(m)
    np.testing.assert_array_equal(r.edge_groups["crack"][:, :2], [[3, 8], [8, 4]])
    seg = Seg3.shape(np.array([-0.5, 0.5])) @ m.points[[3, 4, 8]]
    np.testing.assert_allclose(r.points[r.edge_groups["crack"][:, 2]], seg)
    assert distinct_points(r.points) == len(r.points)


def test_refine_does_not_modify_its_input():
    m = rectangle(2, 2, cell="TRIA6")
    before = RawMesh(m.points.copy(), m.cell_type, m.cells.copy())
    refine_uniform(m, levels=2)
    np.testing.assert_array_equal(m.points, before.points)
    np.testing.assert_array_equal(m.cells, before.cells)


# -- DMPlex built from our own edge DAG ---------------------------------------------
def _plex_summary(dm):
    """Cones, orientations, coordinates and boundary marks of every point."""
    from xfemcontact.mesh.plex import _BOUNDARY
    pstart, pend = dm.getChart()
    cones = [tuple(dm.getCone(p)) for p in range(pstart, pend)]
    orient = [tuple(dm.getConeOrientation(p)) for p in range(pstart, pend)]
    strata = [dm.getDepthStratum(d) for d in range(3)]
    boundary = tuple(dm.getLabel(_BOUNDARY).getStratumIS(1).getIndices())
    return cones, orient, strata, dm.getCoordinatesLocal().getArray().copy(), boundary


@pytest.mark.parametrize("cell", ["QUAD8", "TRIA6"])
def test_plex_from_edge_dag_equals_petsc_interpolation(cell, monkeypatch):
    """The DAG we hand to DMPlexCreateFromDAG is the one createFromCellList(interpolate)
    builds: same points, cones, orientations, coordinates, labels and node map."""
    from xfemcontact._petsc import PETSc
    from xfemcontact.mesh import plex
    raw = rectangle(nx=5, ny=4, cell=cell, diagonal="alternate")
    assert plex._dag_function()
    dm, nodes = plex._build_serial(raw, PETSc.COMM_SELF)
    monkeypatch.setattr(plex, "_DAG_FUNCTION", False)
    ref, ref_nodes = plex._build_serial(raw, PETSc.COMM_SELF)
    got, want = _plex_summary(dm), _plex_summary(ref)
    for g, w in zip(got[:3], want[:3]):
        assert g == w
    np.testing.assert_array_equal(got[3], want[3])
    assert got[4] == want[4]
    np.testing.assert_array_equal(nodes, ref_nodes)
    for name in raw.group_names():
        got, want = ([tuple(lab.getStratumIS(v).getIndices()) if lab.getStratumSize(v) else ()
                      for v in (plex.ENTITY, plex.NODE)] for lab in (dm.getLabel(name), ref.getLabel(name)))
        assert got == want and any(want)


@needs_med
def test_plex_from_edge_dag_on_code_aster_mesh():
    """Every edge of a cell runs from its vertex i to vertex i + 1, whatever the
    input orientation of the neighbouring cells (code_aster's TRIA6 mesh)."""
    from xfemcontact._petsc import PETSc
    from xfemcontact.mesh import plex
    raw = read_mesh(MESHES / "ssnv509b.mmed")
    dm, nodes = plex._build_serial(raw, PETSc.COMM_SELF)
    cs, ce = dm.getHeightStratum(0)
    vs = dm.getDepthStratum(0)[0]
    vertex_node = nodes[vs:vs + raw.vertex_nodes.size]
    for c in range(cs, ce, 37):
        cone, orient = dm.getCone(c), dm.getConeOrientation(c)
        for i, (e, o) in enumerate(zip(cone, orient)):
            a, b = vertex_node[dm.getCone(e) - vs]
            if o < 0:
                a, b = b, a
            assert (a, b) == (raw.cells[c, i], raw.cells[c, (i + 1) % 3])
            assert nodes[e] == raw.cells[c, 3 + i]
