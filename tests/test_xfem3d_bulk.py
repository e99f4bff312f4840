"""X-FEM enrichment in 3-D, end to end, for the interface laws ``bonded`` and ``free``.

* bonded: a box cut by planes (axis-aligned, inclined, through vertices, along a mesh
  plane) and by a sphere reproduces a linear displacement imposed on its boundary to
  round-off, on HEXA20 and TETRA10; so does a uniform stress applied by tractions on
  faces the interface cuts, and a quadratic field with its body force in cut cells;
* free: two blocks cut apart by a plane, each in its own uniform stress, held and
  loaded on its own: each side gets its exact field, and the jump across the interface
  is the difference of the two;
* the volumes of the sides from the assembled quadrature are exact for planar cuts;
* 2 and 3 processes give the answer of one; the rigid-body check knows the two sides of a
  free interface (contact in 3-D: tests/test_contact3d.py, tests/test_gauss3d.py).
"""
import numpy as np
import pytest

from conftest import CASES, results, run_cli, write_case
from test_xfem3d import cube_volume_below
from xfemcontact.case import load_case
from xfemcontact.model import Model
from xfemcontact.post.postmesh import displacement_at
from xfemcontact.xfem import geometry as xgeo
from xfemcontact.xfem import integration3d

SOLIDS = ("HEXA20", "TETRA10")
E, NU = 2.0e5, 0.3
LAM, MU = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
EPS = np.array([[1.0, 0.4, -0.3], [0.4, -0.6, 0.2], [-0.3, 0.2, 0.8]]) * 1e-3
LINEAR = ("1e-3*(1.0*x + 0.4*y - 0.3*z) + 2e-4", "1e-3*(0.4*x - 0.6*y + 0.2*z) - 1e-4",
          "1e-3*(-0.3*x + 0.2*y + 0.8*z) + 3e-4")
FACES = ("left", "right", "front", "back", "bottom", "top")
#: level sets cutting the unit cube meshed with 3 x 3 x 3 (HEXA20) cells
CUTS = {"axis": "x - 0.37",
        "inclined": "x + 0.5*y - 0.3*z - 0.41",
        "vertices": "x + y - 1",                         # through vertices and edges of the mesh
        "mesh plane": "y - 1/3",                        # along cell faces: no cut cell
        "sphere": "(x - 0.2)**2 + (y - 0.3)**2 + z**2 - 0.81"}
#: volume of the LN < 0 side of the unit cube for the planar cuts
PLANES = {"axis": 0.37, "inclined": cube_volume_below((1, 0.5, -0.3), 0.41), "vertices": 0.5}


def linear(x):
    return x @ EPS.T + np.array([2e-4, -1e-4, 3e-4])


def sigma(eps):
    return LAM * np.trace(eps) * np.eye(3) + 2 * MU * eps


def voigt(s):
    return np.array([s[0, 0], s[1, 1], s[2, 2], s[0, 1], s[0, 2], s[1, 2]])


def solve(tmp_path, text):
    model = Model.from_case(load_case(write_case(tmp_path, text)))
    assert model.solve() > 0
    return model


def stresses(model):
    """All quadrature-point stresses ``(k, 6)``, points ``(k, 3)`` and sides ``(k,)``."""
    v = model.stresses()
    return (np.concatenate([p.stress[p.w != 0] for p in v]), np.concatenate([p.x[p.w != 0] for p in v]),
            np.concatenate([np.broadcast_to(p.side, p.w.shape)[p.w != 0] for p in v]))


def cube(cell, level_set, law, loads, n=3):
    return f"""
        [mesh]
        box = {{nx = {n}, ny = {n}, nz = {n}, x = [0, 1], y = [0, 1], z = [0, 1], cell = "{cell}"}}
        [material]
        E = {E}
        nu = {NU}
        model = "3D"
        [interface]
        level_set = "{level_set}"
        law = "{law}"
        {loads}
        """


IMPOSED = f"""
        [[dirichlet]]
        group = {list(FACES)}
        DX = "{LINEAR[0]}"
        DY = "{LINEAR[1]}"
        DZ = "{LINEAR[2]}"
        """


@pytest.mark.parametrize("cut", CUTS)
@pytest.mark.parametrize("cell", SOLIDS)
def test_bonded_reproduces_a_linear_field(tmp_path, cell, cut):
    """A linear displacement imposed on the whole boundary, a bonded interface: every node
    to 1e-10 (relative), the stress at every quadrature point of both sides to 1e-8."""
    model = solve(tmp_path, cube(cell, CUTS[cut], "bonded", IMPOSED))
    geo = model.geo
    assert geo is not None and geo.enriched.any()
    assert len(geo.cut_cells) > 0 or cut == "mesh plane"
    x, u = model.mesh.x, model.displacement()
    assert np.abs(u - linear(x)).max() <= 1e-10 * np.abs(linear(x)).max()
    s, _, side = stresses(model)
    assert {-1, 1} <= set(np.unique(side).astype(int))
    ref = voigt(sigma(EPS))
    assert np.abs(s - ref).max() <= 1e-8 * np.abs(ref).max()


@pytest.mark.parametrize("cut", ["inclined", "sphere"])
@pytest.mark.parametrize("cell", SOLIDS)
def test_bonded_linear_field_on_distorted_cells(tmp_path, cell, cut):
    """The same on cells whose interior vertices are moved by 0.05 m (curved and
    non-affine parents: every cut cell takes the curved sub-cells' rule): 1e-10 (measured:
    HEXA20 2e-15 plane, 7e-14 sphere; TETRA10 1e-15)."""
    from test_fem3d import distorted
    from xfemcontact.mesh.generate import box

    raw = distorted(box(3, 3, 3, x=(0, 1), y=(0, 1), z=(0, 1), cell=cell), 0.05)
    model = Model.from_case(load_case(write_case(tmp_path, cube(cell, CUTS[cut], "bonded", IMPOSED))), raw)
    assert model.solve() > 0 and len(model.geo.cut_cells) > 0
    x, u = model.mesh.x, model.displacement()
    assert np.abs(u - linear(x)).max() <= 1e-10 * np.abs(linear(x)).max()


@pytest.mark.parametrize("cut", ["inclined", "sphere"])
@pytest.mark.parametrize("cell", SOLIDS)
def test_bonded_tractions_on_cut_faces(tmp_path, cell, cut):
    """The uniform stress of cases/validation/box_plane_bonded_hexa20.toml (tractions
    sigma n on every face, the cut faces x = 0, y = 0, z = 0 included; one component
    imposed on each of them): exact, on both cells, planar and spherical cuts."""
    text = (CASES / "validation" / "box_plane_bonded_hexa20.toml").read_text()
    text = text.replace('cell = "HEXA20"', f'cell = "{cell}"')
    if cut == "sphere":
        text = text.replace('level_set = "x + 0.5*y - 0.3*z - 0.41"',
                            'level_set = "(x - 0.2)**2 + (y - 0.3)**2 + z**2 - 0.81"')
    model = solve(tmp_path, text)
    x, u = model.mesh.x, model.displacement()
    exact = x @ EPS.T
    assert np.abs(u - exact).max() <= 1e-10 * np.abs(exact).max()
    ref = voigt(sigma(EPS))
    assert np.abs(stresses(model)[0] - ref).max() <= 1e-8 * np.abs(ref).max()


def test_tractions_on_cut_faces_split_by_side(tmp_path):
    """The sub-faces of a cut face tile it (each side's area, summed, is the face's), and
    the split follows the interface: on the face x = 0 cut by the plane y = 0.41 + 0.3 z,
    the LN < 0 part has the exact area."""
    model = Model.from_case(load_case(write_case(tmp_path, cube("HEXA20", "y - 0.3*z - 0.41", "free", IMPOSED))))
    mesh, geo = model.mesh, model.geo
    nodes, cell, local = mesh.group_faces("left")
    cut = geo.cell_side[cell] == 0
    rows = np.searchsorted(geo.subcells.cells, cell[cut])
    sub = type(geo.subcells)(geo.subcells.cells[rows], geo.subcells.nodes[rows], geo.subcells.side[rows])
    pts, side = integration3d.cut_face_points(mesh.element, mesh.x[mesh.cell_nodes[sub.cells]], sub, local[cut])
    assert np.allclose(pts.normal[pts.w != 0], [-1, 0, 0], atol=1e-14)
    whole = [(geo.cell_side[cell[~cut]] == s).sum() / 9 for s in (-1, 1)]      # uncut faces, 1/9 m^2 each
    area = [whole[i] + (pts.w * (side == s)).sum() for i, s in enumerate((-1, 1))]
    assert abs(area[0] - (0.41 + 0.15)) < 1e-13 and abs(sum(area) - 1.0) < 1e-13


@pytest.mark.parametrize("cell", SOLIDS)
def test_bonded_body_force_in_cut_cells(tmp_path, cell):
    """A quadratic displacement and its constant body force, imposed on the boundary, an
    inclined bonded interface: exact at every node (the body force integrated on the
    sub-tetrahedra of both sides)."""
    grad_div = np.array([4e-3, 1e-3, -2e-3])          # div u = 4e-3 x + 1e-3 y - 2e-3 z
    f = -(LAM + MU) * grad_div - MU * np.array([4e-3, 1e-3, -2e-3])
    q = ("2e-3*x*x + 1e-3*y*z", "-1e-3*x*z + 5e-4*y*y", "3e-3*x*y - 1e-3*z*z")
    loads = f"""
        [[dirichlet]]
        group = {list(FACES)}
        DX = "{q[0]}"
        DY = "{q[1]}"
        DZ = "{q[2]}"
        [body_force]
        FX = {f[0]!r}
        FY = {f[1]!r}
        FZ = {f[2]!r}
        """
    model = solve(tmp_path, cube(cell, CUTS["inclined"], "bonded", loads, n=2))
    X, Y, Z = model.mesh.x.T
    exact = np.stack([2e-3 * X * X + 1e-3 * Y * Z, -1e-3 * X * Z + 5e-4 * Y * Y, 3e-3 * X * Y - 1e-3 * Z * Z], 1)
    assert np.abs(model.displacement() - exact).max() <= 1e-10 * np.abs(exact).max()


# -- free: two blocks ---------------------------------------------------------------------
SL, SR, SHIFT, C = 100.0, -60.0, np.array([1e-5, 0.0, 2e-5]), 1.13


def block_field(x, s, shift):
    """Uniform sigma_yy = s: u = (-nu s x / E, s y / E, -nu s z / E) + shift (E = 1e6, nu = 0.25)."""
    return np.stack([-0.25 * s * x[..., 0], s * x[..., 1], -0.25 * s * x[..., 2]], axis=-1) / 1e6 + shift


@pytest.mark.parametrize("cell", SOLIDS)
def test_free_blocks_each_get_their_own_field(tmp_path, cell):
    """cases/validation/box_plane_free_hexa20.toml: each block (x + 0.3 z < 1.13, > 1.13)
    in its own uniform stress, held by its own end face and loaded by its own share of the
    cut faces y = 0, y = 1: every node has its side's exact field, and the jump across the
    interface is the difference of the two fields, at the Gauss points of every facet."""
    text = (CASES / "validation" / "box_plane_free_hexa20.toml").read_text().replace(
        'cell = "HEXA20"', f'cell = "{cell}"')
    model = solve(tmp_path, text)
    mesh, geo = model.mesh, model.geo
    x = mesh.x
    plus = x[:, 0] + 0.3 * x[:, 2] - C > 0
    exact = np.where(plus[:, None], block_field(x, SR, SHIFT), block_field(x, SL, 0.0))
    assert np.abs(model.displacement() - exact).max() <= 1e-10 * np.abs(exact).max()
    s, xq, _ = stresses(model)
    ln = xq @ [1, 0, 0.3] - C
    assert np.abs(s[:, 1] - np.where(ln > 0, SR, SL)).max() < 1e-9
    assert np.abs(np.delete(s, 1, axis=1)).max() < 1e-9
    # the jump at the facets' Gauss points
    fac = geo.facets
    xc = x[mesh.cell_nodes[fac.cells]]
    pts = integration3d.facet_points(mesh.element, xc, geo.phi[mesh.cell_nodes[fac.cells]], fac)
    xl = model.local_solution()
    jump = (displacement_at(model, xl, fac.cells, pts.xi, np.ones(len(fac.cells)))
            - displacement_at(model, xl, fac.cells, pts.xi, -np.ones(len(fac.cells))))
    live = pts.w != 0
    expected = block_field(pts.x, SR, SHIFT) - block_field(pts.x, SL, 0.0)
    assert live.sum() > 0
    assert np.abs(jump - expected)[live].max() <= 1e-10 * np.abs(expected[live]).max()
    assert np.abs(pts.x[live] @ [1, 0, 0.3] - C).max() < 1e-12           # points on the plane
    area = sum(p.w.sum() for p in geo.interface_points(mesh))             # the plane across the box
    assert abs(area - np.sqrt(1.09)) < 1e-12


@pytest.mark.parametrize("cut", PLANES)
@pytest.mark.parametrize("cell", SOLIDS)
def test_side_volumes_from_the_assembled_quadrature(tmp_path, cell, cut):
    """The weights of the quadrature the assembly uses (cut and uncut cells), summed by
    side, are the volumes of the two sides of the unit cube, to 1e-12."""
    model = Model.from_case(load_case(write_case(tmp_path, cube(cell, CUTS[cut], "free", IMPOSED))))
    mesh, geo = model.mesh, model.geo
    vol = {-1: 0.0, 1: 0.0}
    for pts in xgeo.cell_points(mesh, geo, np.arange(len(mesh.cells))):
        for s in vol:
            vol[s] += float((pts.w * (pts.side == s)).sum())
    below = PLANES[cut]
    assert abs(vol[-1] - below) < 1e-12 and abs(vol[1] - (1 - below)) < 1e-12


# -- command line: processes ----------------------------------------------------------------
@pytest.mark.mpi
@pytest.mark.parametrize("name", ["box_plane_free_hexa20", "box_sphere_bonded_tetra10"])
def test_processes_give_the_one_process_answer(run_once, name):
    import h5py

    path = CASES / "validation" / f"{name}.toml"
    runs = {}
    for np_ in (1, 2, 3):                  # one process: the run of test_validation_cases_run_from...
        done, out = run_once(path, np_=np_ if np_ > 1 else None)
        assert done.returncode == 0, done.stdout + done.stderr
        assert all(t["ok"] for t in results(out)["tests"])
        runs[np_] = out
    assert results(runs[1])["geometry"]["cut_cells"] == results(runs[3])["geometry"]["cut_cells"]
    assert len(results(runs[3])["partition"]["cells_per_process"]) == 3
    with h5py.File(runs[1] / "fields.h5") as a:
        ref = {k: a[k][()] for k in a}
    scale = max(np.abs(ref[k]).max() for k in ("data2", "data3", "data4"))
    for np_ in (2, 3):
        with h5py.File(runs[np_] / "fields.h5") as b:
            assert list(b) == list(ref)
            for k in ("data0", "data1"):              # points and cells: the same numbering
                assert np.array_equal(ref[k], b[k][()]) if k == "data1" else np.allclose(ref[k], b[k][()],
                                                                                         rtol=0, atol=1e-14)
            for k in ("data2", "data3", "data4"):     # DX, DY, DZ
                assert np.abs(ref[k] - b[k][()]).max() <= 1e-10 * scale


#: the free blocks' jump ([u] = u(+) - u(-), box_plane_free_hexa20.toml) along n = (1, 0, 0.3) / sqrt(1.09)
#: and its tangential magnitude, as formulas of x, y, z
FREE_JUMP = ("(-nu*(sR - sL)*x/E + 1e-5)", "((sR - sL)*y/E)", "(-nu*(sR - sL)*z/E + 2e-5)")
FREE_GAP = f"({FREE_JUMP[0]} + 0.3*{FREE_JUMP[2]})/sqrt(1.09)"
FREE_SLIP = f"sqrt({FREE_JUMP[0]}**2 + {FREE_JUMP[1]}**2 + {FREE_JUMP[2]}**2 - ({FREE_GAP})**2)"


@pytest.mark.parametrize("law", ("free", "bonded"))
def test_interface_fields_of_free_and_bonded_in_3d(tmp_path, law):
    """The laws free and bonded give the interface values of 2-D's results-only problem in
    3-D: gap and slip (the jump's normal and tangential parts) at the facets' Gauss points
    in interface.csv, [[test]] on them (here against the free blocks' closed form, zero when
    bonded), LAGS_C = LAGS_F1 = LAGS_F2 = T = 0, contact 1 when bonded and 0 when free; the
    interface surface file carries the same fields at the facets' nodes."""
    import meshio

    text = (CASES / "validation" / "box_plane_free_hexa20.toml").read_text().replace('law = "free"', f'law = "{law}"')
    gap, slip = (FREE_GAP, FREE_SLIP) if law == "free" else ("0*x", "0*x")
    text = text.replace("[reference]\n", f'[reference]\ngap = "{gap}"\nslip = "{slip}"\n')
    tests = "".join(f'[[test]]\nfield = "{f}"\ntype = "MAX_ERROR"\ntolerance = 1e-15\ncriterion = "ABSOLU"\n\n'
                    for f in ("gap", "slip"))
    if law == "bonded":                 # another solution: the free blocks' tests do not hold
        text = text[:text.index("[[test]]")] + "[output]\nplots = false\n"
    text = text.replace("[output]\nplots = false", tests + '[output]\nplots = false\nformats = ["xdmf"]')
    out = tmp_path / "out"
    done = run_cli(["run", write_case(tmp_path, text), "-o", out])
    assert done.returncode == 0, done.stderr
    r = results(out)
    assert [t["name"] for t in r["tests"] if not t["ok"]] == []
    assert {t["field"] for t in r["tests"]} >= {"gap", "slip"}
    from xfemcontact.output import interface_csv

    c = interface_csv.read(out / "interface.csv")
    assert len(c["x"]) > 0 and abs(c["w"].sum() - np.sqrt(1.09)) < 1e-12
    for f in ("LAGS_C", "LAGS_F1", "LAGS_F2", "T", "sliding"):
        assert not c[f].any()
    assert (c["contact"] == (1 if law == "bonded" else 0)).all()
    jump = np.abs(c["gap"]).max() + c["slip"].max()
    assert (jump > 1e-6) if law == "free" else (jump < 1e-15)
    m = meshio.read(out / "interface.xdmf")
    assert m.cells[0].type == "triangle6"
    for f in ("LAGS_C", "T", "contact"):
        assert np.array_equal(m.point_data[f], np.full(len(m.points), 1.0 if f == "contact" and law == "bonded"
                                                        else 0.0))
    if law == "free":
        x, y, z = m.points.T
        nu, E, sL, sR = 0.25, 1.0e6, 100.0, -60.0
        exact = (((-nu * (sR - sL) * x / E + 1e-5) + 0.3 * (-nu * (sR - sL) * z / E + 2e-5)) / np.sqrt(1.09))
        assert np.abs(m.point_data["gap"] - exact).max() < 1e-15


def test_free_sides_are_separate_bodies(tmp_path):
    """law = "free": the block on the LN > 0 side, held by nothing, is refused (each side
    is a body); with law = "bonded" the same case runs, and so does the free one held by
    a face that the interface cuts."""
    loads = f"""
        [[dirichlet]]
        group = "left"
        DX = "{LINEAR[0]}"
        DY = "{LINEAR[1]}"
        DZ = "{LINEAR[2]}"
        """
    done = run_cli(["run", write_case(tmp_path, cube("HEXA20", CUTS["axis"], "free", loads), "free.toml"),
                    "-o", tmp_path / "o1"])
    assert done.returncode == 2
    assert "rigid-body motion not prevented for the part on the LN > 0 side" in done.stderr, done.stderr
    done = run_cli(["run", write_case(tmp_path, cube("HEXA20", CUTS["axis"], "bonded", loads), "bonded.toml"),
                    "-o", tmp_path / "o2"])
    assert done.returncode == 0, done.stderr
    # a face the interface cuts holds both sides (its enriched nodes' Heaviside dofs fixed)
    cut_face = loads.replace('group = "left"', 'group = "bottom"')
    done = run_cli(["run", write_case(tmp_path, cube("HEXA20", CUTS["axis"], "free", cut_face), "both.toml"),
                    "-o", tmp_path / "o3"])
    assert done.returncode == 0, done.stderr
    assert all(t["ok"] for t in results(tmp_path / "o3")["tests"])


@pytest.mark.parametrize("name", ["box_plane_bonded_hexa20", "box_sphere_bonded_tetra10", "box_plane_free_hexa20"])
def test_validation_cases_run_from_the_command_line(tmp_path, run_once, name):
    """The 3-D validation cases: exit 0, every test OK, the post mesh holds the
    sub-tetrahedra of the cut cells (both sides)."""
    import meshio

    done, out = run_once(CASES / "validation" / f"{name}.toml")      # shared (conftest.Runs)
    assert done.returncode == 0, done.stdout + done.stderr
    assert all(t["ok"] for t in results(out)["tests"])
    text = (CASES / "validation" / f"{name}.toml").read_text().replace(
        "plots = false", 'plots = false\nformats = ["xdmf", "vtu"]')
    done = run_cli(["run", write_case(tmp_path, text), "-o", tmp_path / "vtu"])
    assert done.returncode == 0, done.stdout + done.stderr
    r = results(tmp_path / "vtu")
    assert r["tests"] and all(t["ok"] for t in r["tests"])
    # meshio cannot read mixed XDMF topologies with 3-D quadratic cells back: the VTU file
    m = meshio.read(tmp_path / "vtu" / "fields.vtu")
    assert "tetra10" in [b.type for b in m.cells]
    sides = np.concatenate(m.cell_data["side"])
    assert {-1, 1} <= set(np.unique(sides).tolist())


def test_load_steps_with_tractions_on_cut_faces(tmp_path):
    """box_plane_free_hexa20.toml with its tractions ramped over [instants] (the loads of
    each instant rebuilt on the cut faces, xfemcontact.history.loading): exact at t = 1."""
    text = (CASES / "validation" / "box_plane_free_hexa20.toml").read_text()
    text = text.replace('[[traction]]\ngroup = "back"', '[instants]\nvalues = [0.0, 0.5, 1.0]\n\n'
                        '[functions]\nramp = { vale = [0.0, 0.0, 1.0, 1.0] }\n\n'
                        '[[traction]]\nfonc_mult = "ramp"\ngroup = "back"')
    text = text.replace('[[traction]]\ngroup = "front"', '[[traction]]\nfonc_mult = "ramp"\ngroup = "front"')
    assert text.count("fonc_mult") == 2
    done = run_cli(["run", write_case(tmp_path, text), "-o", tmp_path / "out"])
    assert done.returncode == 0, done.stdout + done.stderr
    r = results(tmp_path / "out")
    assert r["tests"] and all(t["ok"] for t in r["tests"])
