"""Post-processing (issue 5): the POST_MAIL_XFEM-like mesh, interface.csv, plots, report.md.

Runs the command line on SSNV509 a (QUAD8, mixed quad8 + triangle6 post mesh), the
opening case (known displacement on each side) and a TRIA6 case, and once under
``mpirun -n 2`` to check that the files do not depend on the partition.
"""
import pathlib
import re
import xml.etree.ElementTree as ET

import h5py
import meshio
import numpy as np
import pytest

from conftest import CASES, results, run_cli, write_case
from xfemcontact.output import interface_csv
from xfemcontact.post import plots

ARC_LENGTH = 10.797891203332386           # SSNV509 interface length (m)
XC, YC = 5.0, 11.77
OUTPUT_ALL = '\n[output]\nformats = ["xdmf", "vtu"]\n'
NO_PLOTS = '\n[output]\nformats = ["xdmf", "vtu", "med"]\nplots = false\n'
TIMEOUT = 120
PNGS = ("plot_multipliers.png", "plot_deformed.png", "plot_status.png", "plot_convergence.png")


def run_case(directory, source, extra, np=None, name="case.toml"):
    """Run ``source`` + ``extra`` TOML text into ``directory/out``; returns the folder."""
    path = write_case(directory, pathlib.Path(source).read_text() + extra, name)
    out = pathlib.Path(directory) / "out"
    proc = run_cli(["run", path, "-o", out], np=np, timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return out


@pytest.fixture(scope="module")
def ssnv509a(tmp_path_factory):
    return run_case(tmp_path_factory.mktemp("a"), CASES / "ssnv509a.toml", OUTPUT_ALL)


@pytest.fixture(scope="module")
def opening(tmp_path_factory):
    return run_case(tmp_path_factory.mktemp("open"), CASES / "validation" / "opening.toml", NO_PLOTS)


def post_mesh(out):
    return meshio.read(out / "fields.vtu")


def level_set(x, y):
    return (x - XC) ** 2 + (y - YC) ** 2 - 64.27


def xdmf_arrays(out):
    """{name: array} of fields.xdmf (geometry, topology, attributes) read through h5py."""
    root = ET.parse(out / "fields.xdmf").getroot()
    grid = root.find("Domain/Grid")
    out_arrays = {}
    with h5py.File(out / "fields.h5", "r") as h5:
        def data(item):
            file, path = item.text.strip().split(":")
            assert file == "fields.h5"           # relative: the folder can be moved
            return h5[path][()]

        out_arrays["geometry"] = data(grid.find("Geometry/DataItem"))
        out_arrays["topology"] = data(grid.find("Topology/DataItem"))
        out_arrays["topology_type"] = grid.find("Topology").get("TopologyType")
        for att in grid.findall("Attribute"):
            out_arrays[att.get("Name")] = data(att.find("DataItem"))
    return out_arrays


def mixed_cells(topology):
    """Decode an XDMF Mixed topology of Triangle_6 (0x24) and Quadrilateral_8 (0x25)."""
    sizes = {0x24: 6, 0x25: 8}
    cells, i = [], 0
    while i < len(topology):
        n = sizes[int(topology[i])]
        cells.append((int(topology[i]), topology[i + 1:i + 1 + n]))
        i += 1 + n
    return cells


def cell_areas(points, cells, kind):
    """Areas of isoparametric quad8 / triangle6 cells (Gauss quadrature)."""
    from xfemcontact.fem.elements import element

    el = element({"quad8": "QUAD8", "triangle6": "TRIA6"}[kind])
    q, w = el.quadrature(4)
    return el.jacobian_dets(points[cells][:, :, :2], q) @ w


# --- the post-processing mesh ------------------------------------------------------------

def test_post_mesh_cells_points_and_area(ssnv509a):
    """Uncut QUAD8 kept, cut cells replaced by their sub-triangles, tiling the plate."""
    from xfemcontact.case import load_case
    from xfemcontact.model import Model

    model = Model(load_case(CASES / "ssnv509a.toml"))
    n_cut = len(model.geo.cut_cells)
    n_sub = int((model.geo.subcells.side != 0).sum())
    r = results(ssnv509a)
    assert r["geometry"]["cut_cells"] == n_cut == 28
    m = post_mesh(ssnv509a)
    blocks = {c.type: c.data for c in m.cells}
    assert list(blocks) == ["quad8", "triangle6"]
    assert len(blocks["quad8"]) == 400 - n_cut
    assert len(blocks["triangle6"]) == n_sub
    area = sum(cell_areas(m.points, c, t).sum() for t, c in blocks.items())
    assert area == pytest.approx(100.0, rel=1e-12)
    for t, c in blocks.items():
        assert np.all(cell_areas(m.points, c, t) > 0)            # counter-clockwise, not folded
    # every point is used; points at one place are exactly the two copies of an interface point
    used = np.zeros(len(m.points), bool)
    for c in blocks.values():
        used[c.ravel()] = True
    assert used.all()
    key = np.round(m.points[:, :2] / 1e-9).astype(np.int64)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    n_places = len(counts)
    nf = m.point_data["NFISSU"]
    assert np.all(counts <= 2)
    assert np.array_equal(counts[inverse.ravel()] == 2, nf != 0)
    # one interface point per crossing (open curve: k + 1) and three per segment inside its cell
    n_itf = 4 * n_cut + 1
    assert (nf == -1).sum() == (nf == 1).sum() == n_itf
    assert len(m.points) == n_places + n_itf
    # the cell fields: input id, sub-cell index, side
    cd = {k: np.concatenate(v) for k, v in m.cell_data.items()}
    assert np.array_equal(np.unique(cd["cell"]), np.arange(400))
    sub = cd["subcell"][len(blocks["quad8"]):]
    assert np.all(m.cell_data["subcell"][0] == -1) and np.all(sub >= 0)
    assert set(np.unique(cd["side"])) == {-1, 1}
    cut_ids = np.unique(m.cell_data["cell"][1])
    assert len(cut_ids) == n_cut
    assert not np.isin(m.cell_data["cell"][0], cut_ids).any()
    # cells ordered by (input cell, sub-cell) in each block
    for b in range(2):
        order = np.lexsort((m.cell_data["subcell"][b], m.cell_data["cell"][b]))
        assert np.array_equal(order, np.arange(len(order)))


def test_interface_copies_lie_on_the_interface(ssnv509a):
    m = post_mesh(ssnv509a)
    nf = m.point_data["NFISSU"]
    minus = m.points[nf == -1, :2]
    plus = m.points[nf == 1, :2]
    np.testing.assert_allclose(np.sort(minus, axis=0), np.sort(plus, axis=0), atol=1e-12)
    # ends and mid-points of the segments are on LN = 0, the quarter points (mid-nodes of the
    # sub-triangle edges on the interface) within O(h^3) of it
    dist = np.abs(level_set(minus[:, 0], minus[:, 1])) / (2 * np.sqrt(64.27))
    assert dist.max() < 1e-6
    assert (dist < 1e-12).sum() >= 29 + 28
    # sub-triangles of the - side use only - copies, and conversely
    tri = m.cells_dict["triangle6"]
    side = m.cell_data_dict["side"]["triangle6"]
    for s in (-1, 1):
        assert not np.isin(nf[tri[side == s]], [-s]).any()


def test_stresses_per_cell_and_sub_cell(ssnv509a):
    m = post_mesh(ssnv509a)
    for name, ref, tol in (("SIYY", -0.1, 2e-5), ("SIXX", 0.0, 2e-5), ("SIXY", 0.0, 2e-5),
                           ("EPYY", -1e-7, 2e-11)):
        v = np.concatenate(m.cell_data[name])
        assert np.abs(v - ref).max() < tol, name


def test_displacement_of_each_side_opening(opening):
    """Top block translated by (0, 1e-6), bottom fixed: the two copies differ by the jump."""
    m = post_mesh(opening)
    nf = m.point_data["NFISSU"]
    dx, dy = m.point_data["DX"], m.point_data["DY"]
    assert (nf == -1).sum() == (nf == 1).sum() > 0
    np.testing.assert_allclose(dy[nf == -1], 1e-6, atol=1e-15)
    np.testing.assert_allclose(dy[nf == 1], 0.0, atol=1e-15)
    np.testing.assert_allclose(dx[nf != 0], 0.0, atol=1e-15)
    # elsewhere: the side of the point decides
    above = level_set(m.points[:, 0], m.points[:, 1]) < 0
    np.testing.assert_allclose(dy[(nf == 0) & above], 1e-6, atol=1e-15)
    np.testing.assert_allclose(dy[(nf == 0) & ~above], 0.0, atol=1e-15)
    # open everywhere: no contact, no multiplier
    assert not m.point_data["contact"].any()
    assert np.abs(m.point_data["LAGS_C"]).max() < 1e-12


def test_med_file_has_the_nfissu_groups(opening):
    """fields.med (Salome, code_aster): 2-D points, the same fields, node groups NM / NP / NFISSU."""
    med = meshio.read(opening / "fields.med")
    vtu = post_mesh(opening)
    assert med.points.shape[1] == 2
    np.testing.assert_array_equal(med.points, vtu.points[:, :2])
    assert [c.type for c in med.cells] == [c.type for c in vtu.cells]
    assert med.point_tags == {1: ["NFISSU", "NM"], 2: ["NFISSU", "NP"]}
    nf = vtu.point_data["NFISSU"]
    np.testing.assert_array_equal(med.point_data["point_tags"], np.select([nf == -1, nf == 1], [1, 2], 0))
    np.testing.assert_array_equal(med.point_data["DY"], vtu.point_data["DY"])
    np.testing.assert_array_equal(med.cell_data["SIYY"][1], vtu.cell_data["SIYY"][1])


def test_multipliers_at_interface_points_match_the_table(ssnv509a):
    m = post_mesh(ssnv509a)
    nf = m.point_data["NFISSU"]
    table = results(ssnv509a)["interface"]
    tx, ty = np.array(table["x"]), np.array(table["y"])
    for s in (-1, 1):
        idx = np.nonzero(nf == s)[0]
        d = np.hypot(m.points[idx, 0][:, None] - tx[None], m.points[idx, 1][:, None] - ty[None])
        j = np.argmin(d, axis=1)
        at_end = d[np.arange(len(idx)), j] < 1e-9       # the ends of the segments (both cells' rows)
        assert at_end.sum() == 28 + 1
        for f in ("LAGS_C", "LAGS_F1"):
            np.testing.assert_allclose(m.point_data[f][idx[at_end]], np.array(table[f])[j[at_end]],
                                       atol=1e-10, rtol=0)
        # mid and quarter points of the segments carry values too
        assert np.all(m.point_data["LAGS_C"][idx] < -0.06)
        assert np.all(m.point_data["contact"][idx] == 1)
    off = nf == 0
    assert not m.point_data["LAGS_C"][off].any() and not m.point_data["LAGS_F1"][off].any()


def test_xdmf_holds_the_same_mesh_and_fields(ssnv509a):
    """fields.xdmf (Mixed topology, which meshio 5.0 cannot read back) = fields.vtu."""
    x = xdmf_arrays(ssnv509a)
    m = post_mesh(ssnv509a)
    assert x["topology_type"] == "Mixed"
    np.testing.assert_array_equal(x["geometry"], m.points)
    cells = mixed_cells(x["topology"])
    quads = np.array([c for t, c in cells if t == 0x25])
    tris = np.array([c for t, c in cells if t == 0x24])
    np.testing.assert_array_equal(quads, m.cells_dict["quad8"])
    np.testing.assert_array_equal(tris, m.cells_dict["triangle6"])
    for name, v in m.point_data.items():
        np.testing.assert_array_equal(x[name], v)
    for name, v in m.cell_data.items():
        np.testing.assert_array_equal(x[name], np.concatenate(v))


def test_tria6_post_mesh_reads_back_with_meshio(tmp_path):
    out = run_case(tmp_path, CASES / "validation" / "slip_straight_tria6.toml",
                   '\n[output]\nplots = false\n')
    m = meshio.read(out / "fields.xdmf")
    assert [c.type for c in m.cells] == ["triangle6"]
    r = results(out)
    nf = m.point_data["NFISSU"]
    assert (nf == -1).sum() == (nf == 1).sum() > 0
    assert len(np.unique(m.cell_data["cell"][0])) == r["mesh"]["cells"]
    area = cell_areas(m.points, m.cells[0].data, "triangle6").sum()
    assert area == pytest.approx(4.0, rel=1e-12)          # [0, 2] x [0, 2]
    assert not any((out / p).exists() for p in PNGS)       # plots = false


# --- interface.csv -------------------------------------------------------------------------

def test_interface_csv_abscissa_and_columns(ssnv509a):
    cols = interface_csv.read(ssnv509a / "interface.csv")
    s = cols["s"]
    assert len(s) == 2 * 28                                # one row per segment end and cell
    assert s[0] == 0.0
    assert np.all(np.diff(s) >= 0)
    assert np.all(np.diff(np.unique(s)) > 0)
    assert s[-1] == pytest.approx(ARC_LENGTH, abs=1e-6)
    assert (cols["curve"] == 0).all()
    # walked from A (x = 0) to C (x = 10); shared points: two rows, two cells, one s
    assert cols["x"][0] == pytest.approx(0.0, abs=1e-12) and cols["x"][-1] == pytest.approx(10.0)
    same = np.diff(s) == 0
    assert same.sum() == 27
    assert np.all(cols["cell"][1:][same] != cols["cell"][:-1][same])
    np.testing.assert_allclose(cols["x"][1:][same], cols["x"][:-1][same], atol=1e-12)
    # s is the length along the curve: chords are shorter, never longer
    chord = np.hypot(np.diff(cols["x"]), np.diff(cols["y"]))
    assert np.all(chord <= np.diff(s) + 1e-12)
    assert np.diff(s)[~same].sum() - chord[~same].sum() > 0
    # on the circle, s is the arc length from A: R (theta_A - theta)
    R = np.sqrt(64.27)
    theta = np.arctan2(cols["y"] - YC, cols["x"] - XC)
    np.testing.assert_allclose(s, R * (theta - theta[0]), atol=1e-5)
    # reference columns
    ref_c = -0.1 * (cols["y"] - YC) ** 2 / ((cols["x"] - XC) ** 2 + (cols["y"] - YC) ** 2)
    np.testing.assert_allclose(cols["LAGS_C_ref"], ref_c, rtol=1e-12)
    np.testing.assert_allclose(cols["LAGS_C_err"], cols["LAGS_C"] - cols["LAGS_C_ref"], atol=1e-15)
    np.testing.assert_allclose(cols["LAGS_F1_err"], cols["LAGS_F1"] - cols["LAGS_F1_ref"], atol=1e-15)
    assert np.abs(cols["LAGS_C_err"]).max() < 2e-5
    assert "gap_ref" not in cols
    # the same values as results.json's interface table
    table = results(ssnv509a)["interface"]
    key = lambda c, x: np.lexsort((x, c))               # noqa: E731
    a, b = key(cols["cell"], cols["x"]), key(np.array(table["cell"]), np.array(table["x"]))
    np.testing.assert_allclose(cols["LAGS_C"][a], np.array(table["LAGS_C"])[b], atol=1e-14)


def test_chain_open_closed_and_several_curves():
    """A closed square loop, an open polyline oriented right to left, shuffled."""
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float) + [5, 5]
    loop = [(sq[i], sq[(i + 1) % 4]) for i in (1, 2, 3, 0)]        # starts at (6, 5)
    line = [(np.array([x + 1, 0.0]), np.array([x, 0.0])) for x in (2, 1, 0)]
    segs = loop + line
    perm = np.array([5, 2, 0, 6, 3, 1, 4])
    start = np.array([segs[i][0] for i in perm])
    stop = np.array([segs[i][1] for i in perm])
    curve, pos, rev = interface_csv.chain(start, stop)
    for i, p in enumerate(perm):
        if p >= 4:      # open: walked from (0, 0), against its orientation: curve 0
            assert (curve[i], pos[i], rev[i]) == (0, 6 - p, True)
        else:           # closed: along its orientation from its least point (5, 5): curve 1
            assert (curve[i], pos[i], rev[i]) == (1, (p + 1) % 4, False)


# --- plots and report ----------------------------------------------------------------------

def test_pngs_are_drawn(ssnv509a):
    import matplotlib.image as mimg

    for name in PNGS:
        path = ssnv509a / name
        assert path.is_file(), name
        assert path.stat().st_size > 10_000, name
        img = mimg.imread(path)
        assert img.shape[0] > 300 and img.shape[1] > 500
        assert img[..., :3].std() > 0.05, name            # not blank


def test_lags_plot_draws_the_csv_data(ssnv509a):
    cols = interface_csv.read(ssnv509a / "interface.csv")
    fig = plots.multipliers_figure(cols, "SSNV509 a")
    lines = {ln.get_label(): ln for ax in fig.axes for ln in ax.get_lines()}
    for f in ("LAGS_C", "LAGS_F1"):
        np.testing.assert_array_equal(lines[f"{f} computed"].get_xydata(), np.c_[cols["s"], cols[f]])
        np.testing.assert_array_equal(lines[f"{f} reference"].get_xydata(), np.c_[cols["s"], cols[f + "_ref"]])
        err = [ln for label, ln in lines.items() if label.startswith(f"{f} error")]
        np.testing.assert_array_equal(err[0].get_xydata(), np.c_[cols["s"], cols[f + "_err"]])
    axes = fig.axes
    assert axes[0].get_ylabel() == "LAGS_C (Pa)"
    assert "(m)" in axes[-1].get_xlabel()
    assert "SSNV509 a" in fig._suptitle.get_text()


def test_report_and_folder(ssnv509a):
    files = sorted(p.name for p in ssnv509a.iterdir() if p.name != ".xfemcontact")
    assert files == sorted(["fields.xdmf", "fields.h5", "fields.vtu", "interface.csv", "report.md",
                            "results.json", *PNGS])
    assert (ssnv509a / ".xfemcontact").is_file()                    # the mark of a result folder
    assert not list(ssnv509a.parent.glob(".out*"))                  # no temporary folder left
    # results.json last (before the mark, written when the folder is put in place)
    mtime = {p.name: p.stat().st_mtime_ns for p in ssnv509a.iterdir() if p.name in files}
    assert mtime["results.json"] >= max(mtime.values())
    text = (ssnv509a / "report.md").read_text()
    r = results(ssnv509a)
    assert text.startswith(f"# {r['title']}")
    for word in ("QUAD8", "| displacement | heaviside | LAGS_C | LAGS_F1 | total |",
                 f"| {r['dofs']['displacement']} | {r['dofs']['heaviside']} | {r['dofs']['LAGS_C']} |",
                 "friction threshold loop", "## Timings", "carriers"):
        assert word in text, word
    rows = [line for line in text.splitlines() if line.startswith("| OK |")]
    assert len(rows) == len(r["tests"]) == 6
    links = re.findall(r"\]\(([^)]+)\)", text)
    assert set(links) == set(files) - {"report.md"}
    assert all((ssnv509a / link).is_file() for link in links)


# --- partition independence ----------------------------------------------------------------

@pytest.mark.mpi
def test_two_processes_write_the_same_files(ssnv509a, tmp_path):
    out = run_case(tmp_path, CASES / "ssnv509a.toml", OUTPUT_ALL, np=2)
    assert results(out)["processes"] == 2
    with h5py.File(ssnv509a / "fields.h5") as a, h5py.File(out / "fields.h5") as b:
        assert sorted(a) == sorted(b)
        for k in a:
            assert a[k].shape == b[k].shape, k
            np.testing.assert_allclose(b[k][()], a[k][()], atol=1e-10, rtol=0, err_msg=k)
    assert (ssnv509a / "fields.xdmf").read_text() == (out / "fields.xdmf").read_text()
    ca = interface_csv.read(ssnv509a / "interface.csv")
    cb = interface_csv.read(out / "interface.csv")
    assert list(ca) == list(cb)
    for k in ca:
        np.testing.assert_allclose(cb[k], ca[k], atol=1e-10, rtol=0, err_msg=k)
