"""Results of 3-D runs: the interface surface, the post mesh's interface points, the 3-D
plots and the floors of the multiplier space.

* interface.xdmf / interface.vtu (meshio reads them back): TRIA6 facets carrying the
  interface fields, exact where the solution is (a sticking inclined plane: LAGS_C,
  LAGS_F1, LAGS_F2, T, zero gap and slip at every node), with the unit normal and the
  tangent basis; the same values at the interface points of fields.vtu; the same file on
  two processes;
* the plots: plot_interface.png, plot_profiles.png, plot_deformed.png drawn; the default
  profile planes and the cut of a plane interface (one straight open curve, the exact
  values along it); the painter's order of view3d (the nearer polygon wins);
* the ``[output]`` profile keys (3-D only, a non-zero normal);
* the L2 projections of an exact field (the floors): exact for fields of the space; the
  sphere's LAGS_C within 1.25 times its floor (bench/contact3d_sphere.py).
"""
import meshio
import numpy as np
import pytest

from conftest import CASES, results, run_cli, write_case
from xfemcontact.case import load_case
from xfemcontact.model import Model
from xfemcontact.post import plots3d, postmesh, view3d
from xfemcontact.post.projection import best_approximation, l2_norm

STICK = CASES / "validation" / "box_incline_stick_hexa20.toml"
#: the sticking inclined plane's tractions (cases/validation/box_incline_stick_hexa20.toml)
EXACT = {"LAGS_C": -100.0, "LAGS_F1": -0.6417094603395502, "T": 40.0, "gap": 0.0, "slip": 0.0,
         "contact": 1.0, "sliding": 0.0}
NORMAL = np.array([-0.099381, 0.04969, 0.993808])


def stick_case(tmp_path, formats='["xdmf", "vtu"]', plots="true", extra=""):
    text = STICK.read_text()
    text = text[:text.index("[output]")] if "[output]" in text else text
    return write_case(tmp_path, text + f"\n[output]\nformats = {formats}\nplots = {plots}\n{extra}")


@pytest.fixture(scope="module")
def stick_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("stick")
    out = tmp / "out"
    done = run_cli(["run", stick_case(tmp), "-o", out])
    assert done.returncode == 0, done.stdout + done.stderr
    return out


def test_interface_surface_file(stick_run):
    """interface.xdmf and interface.vtu: one triangle6 cell per facet, the fields exact at
    every node, the normal the plane's, t1, t2 an orthonormal basis of its plane; the
    area of the facets is the plane's in the box."""
    for name in ("interface.xdmf", "interface.vtu"):
        m = meshio.read(stick_run / name)
        assert [c.type for c in m.cells] == ["triangle6"]
        pd = m.point_data
        for f, v in EXACT.items():
            assert np.abs(pd[f] - v).max() <= 1e-9 * max(abs(v), 1.0) + 1e-15, f
        assert np.abs(np.hypot(pd["LAGS_F1"], pd["LAGS_F2"]) * 0.5 * 100.0 - 40.0).max() < 1e-9
        n, t1, t2 = pd["normal"], pd["t1"], pd["t2"]
        assert np.abs(n - NORMAL).max() < 1e-6
        assert np.abs(np.einsum("ki,ki->k", t1, n)).max() < 1e-14
        assert np.abs(np.cross(t1, t2) - n).max() < 1e-14
        assert np.allclose(pd["displacement"][:, 2], pd["DZ"])
        assert set(m.cell_data) == {"cell"}
        X = m.points
        tri = m.cells[0].data[:, :3]
        area = 0.5 * np.linalg.norm(np.cross(X[tri[:, 1]] - X[tri[:, 0]], X[tri[:, 2]] - X[tri[:, 0]]), axis=1).sum()
        assert abs(area - results(stick_run)["geometry"]["interface_area"]) < 1e-12
    assert np.abs(X @ NORMAL / np.linalg.norm(NORMAL) - (X @ NORMAL / np.linalg.norm(NORMAL)).mean()).max() < 1e-6


def test_post_mesh_interface_points(stick_run):
    """fields.vtu: the interface points (NFISSU = -1 / +1, both copies) carry LAGS_C,
    LAGS_F1, LAGS_F2 and the statuses; every other point 0."""
    m = meshio.read(stick_run / "fields.vtu")
    pd = m.point_data
    on = pd["NFISSU"] != 0
    assert on.sum() > 0 and set(np.unique(pd["NFISSU"][on])) == {-1, 1}
    s = meshio.read(stick_run / "interface.vtu")
    assert on.sum() == 2 * len(s.points)                    # a copy per side of every node
    assert np.abs(pd["LAGS_C"][on] + 100.0).max() < 1e-9
    assert np.abs(pd["LAGS_F1"][on] - EXACT["LAGS_F1"]).max() < 1e-9
    assert np.abs(np.hypot(pd["LAGS_F1"][on], pd["LAGS_F2"][on]) - 0.8).max() < 1e-9
    assert (pd["contact"][on] == 1).all() and not pd["sliding"].any()
    for f in ("LAGS_C", "LAGS_F1", "LAGS_F2", "contact"):
        assert not pd[f][~on].any()


def test_3d_plots_are_drawn(stick_run):
    names = [p.name for p in stick_run.glob("plot_*.png")]
    assert {"plot_interface.png", "plot_profiles.png", "plot_deformed.png"} <= set(names)
    report = (stick_run / "report.md").read_text()
    assert "plot_interface.png" in report and "plot_profiles.png" in report


def test_interface_surface_on_two_processes(stick_run, tmp_path):
    """interface.h5 on 2 processes: the same points, cells and values as on one."""
    import h5py

    out = tmp_path / "np2"
    done = run_cli(["run", stick_case(tmp_path, '["xdmf"]', "false"), "-o", out], np=2)
    assert done.returncode == 0, done.stdout + done.stderr
    with h5py.File(stick_run / "interface.h5") as a, h5py.File(out / "interface.h5") as b:
        assert list(a) == list(b)
        assert np.array_equal(a["data1"][()], b["data1"][()])            # the cells, same numbering
        for k in a:
            assert np.abs(a[k][()] - b[k][()]).max() <= 1e-9 * max(np.abs(a[k][()]).max(), 1e-6), k


@pytest.fixture(scope="module")
def stick_model(tmp_path_factory):
    model = Model.from_case(load_case(stick_case(tmp_path_factory.mktemp("m"), "[]", "false")))
    assert model.solve() > 0
    return model


def test_profiles_of_a_plane(stick_model):
    """The default profile planes of an interface whose normal is mostly along z: x = x_c
    and y = y_c through its centre; each cuts the plane in one straight open curve, walked
    along y and x, with the exact values along it."""
    surface = postmesh.build(stick_model).interface
    planes = plots3d.profile_planes(surface)
    assert [tuple(m) for _, m, _ in planes] == [(1, 0, 0), (0, 1, 0)]
    assert [tuple(e) for _, _, e in planes] == [(0, 1, 0), (1, 0, 0)]
    fields = ("LAGS_C", "LAGS_F1", "gap", "slip")
    ref = {"LAGS_C": lambda x, y, z: -100.0 + 0 * x}
    profiles = plots3d.profile_data(surface, planes, fields, ref)
    for (p, m, e), prof in zip(planes, profiles):
        (curve,) = prof["curves"]
        pts = np.c_[curve["x"], curve["y"], curve["z"]]
        assert np.abs((pts - p) @ m).max() < 1e-12                          # in the plane
        assert np.all(np.diff(pts @ e) > 0)                                 # along its direction
        assert abs(curve["s"][-1] - np.linalg.norm(pts[-1] - pts[0])) < 1e-12   # straight
        assert np.abs(curve["LAGS_C"] + 100.0).max() < 1e-9 and np.abs(curve["LAGS_C_ref"] + 100.0).max() == 0
        assert np.abs(curve["LAGS_F1"] - EXACT["LAGS_F1"]).max() < 1e-9
    (one,) = plots3d.profile_planes(surface, [0.5, 0.5, 0.5], [1.0, 1.0, 0.0])
    assert np.allclose(one[1], np.sqrt(0.5) * np.array([1, 1, 0])) and abs(one[1] @ one[2]) < 1e-15


def test_painter_order(monkeypatch):
    """Two triangles over the same spot at different depths: the one nearer the camera is
    drawn last (polygons) and fills the pixels (image)."""
    X = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1.0]])
    tri = np.array([[3, 4, 5], [0, 1, 2]])                 # the near one (z = 1) first
    R = view3d.view(90.0, -90.0)                            # from above: z towards the camera
    pic = view3d.picture(X, tri, np.array([1.0, 2.0]), R)
    assert list(pic["values"]) == [2.0, 1.0]
    monkeypatch.setattr(view3d, "VECTOR_POLYGONS", 1)      # an image
    monkeypatch.setattr(view3d, "PIXELS", 40)
    img = view3d.picture(X, tri, np.array([1.0, 2.0]), R)["image"]
    assert np.nanmax(img) == 1.0 and np.isfinite(img).sum() > 0.3 * img.size


@pytest.mark.parametrize("keys, message", [
    ("profile_point = [0.5, 0.5]", "output.profile_point: a 3-D key"),
    ("profile_normal = [0, 1]", "output.profile_normal: a 3-D key")])
def test_profile_keys_are_3d_only(tmp_path, keys, message):
    text = (CASES / "ssnv509a.toml").read_text()
    text = text.replace("[output]", f"[output]\n{keys}") if "[output]" in text else text + f"\n[output]\n{keys}\n"
    done = run_cli(["run", write_case(tmp_path, text), "-o", tmp_path / "o"])
    assert done.returncode == 2
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and message in lines[0], done.stderr


def test_zero_profile_normal_is_refused(tmp_path):
    done = run_cli(["run", stick_case(tmp_path, "[]", "false", "profile_normal = [0, 0, 0]"), "-o", tmp_path / "o"])
    assert done.returncode == 2 and "output.profile_normal: must not be the zero vector" in done.stderr


def test_projection_floors(stick_model):
    """The L2 projections onto the run's space and the raw vertex space reproduce a linear
    field (both contain it) and are at most as far from a quadratic one as any field of
    the space (here: the computed LAGS_C, 0 off the constant)."""
    x = stick_model.problem.points.x
    linear = 3.0 * x[..., 0] - 2.0 * x[..., 1] + x[..., 2] + 1.0
    for raw in (False, True):
        assert l2_norm(stick_model, best_approximation(stick_model, linear, raw) - linear) < 1e-12
    quad = x[..., 0] ** 2 + x[..., 1] * x[..., 2]
    floor = l2_norm(stick_model, best_approximation(stick_model, quad) - quad)
    raw = l2_norm(stick_model, best_approximation(stick_model, quad, raw=True) - quad)
    assert 0 < raw <= floor * (1 + 1e-12)
    assert floor < l2_norm(stick_model, np.full(quad.shape, quad.mean()) - quad)


def test_sphere_is_near_its_floor(tmp_path):
    """The sticking sphere of bench/contact3d_sphere.py on 8 x 8 x 8 x 6 TETRA10: the L2
    error of LAGS_C within 1.25 times the L2 error of its best approximation in the run's
    multiplier space (1.12 measured; 1.33 when the edges the sphere crosses twice were
    lifted), which is within 1.02 times the raw vertex space's."""
    c, p, q = np.array([0.4689, 0.5311, 0.4693]), 100.0, 50.0
    text = (CASES / "validation" / "box_sphere_stick_tetra10.toml").read_text()
    model = Model.from_case(load_case(write_case(tmp_path, text)))
    assert model.solve() > 0
    x = model.problem.points.x
    exact = -p - q * ((x[..., 2] - c[2]) / np.linalg.norm(x - c, axis=-1)) ** 2
    lin = model.mesh.element.shape_linear(model.problem.points.xi)
    computed = np.einsum("kqv,kv->kq", lin, model.problem.vertex_values(model.x)[0])
    err = l2_norm(model, computed - exact)
    floor = l2_norm(model, best_approximation(model, exact) - exact)
    raw = l2_norm(model, best_approximation(model, exact, raw=True) - exact)
    assert model.geo.readjustment.double_crossings == 8 and model.geo.readjustment.lifted_edges == 0
    assert raw <= floor <= 1.02 * raw and err <= 1.25 * floor
