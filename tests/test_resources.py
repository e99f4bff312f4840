"""Memory estimate and refusal of cases that cannot fit; phase memory in results.json;
the deformed-mesh image; the plot helper's fallback.  (No test looks at wall times.)"""
import os

import numpy as np
import pytest

from conftest import CASES, results, run_cli, write_case
from xfemcontact import preflight, resources
from xfemcontact.post import plots

SSNV509A = (CASES / "ssnv509a.toml").read_text()


def with_rectangle(nx, cell="QUAD8"):
    head, tail = SSNV509A.split("[mesh]", 1)
    tail = tail.split("\n", 2)[2]
    return (head + f'[mesh]\nrectangle = {{ nx = {nx}, ny = {nx}, x = [0.0, 10.0], y = [0.0, 10.0], '
            f'cell = "{cell}" }}\n' + tail)


def test_estimate_grows_with_the_mesh_and_splits_over_processes():
    small, large = resources.estimate("QUAD8", 320 ** 2), resources.estimate("QUAD8", 1000 ** 2)
    assert small.dofs == 2 * 3 * 320 ** 2
    assert large.factor_entries > 9 * small.factor_entries            # faster than the dofs
    two = resources.estimate("QUAD8", 1000 ** 2, nprocs=2)
    assert two.peak_mb < 0.7 * large.peak_mb and two.total_mb > large.total_mb
    # the N = 1000 runs of the bench: 15.2 GB on one process, 9.4 GB per process on two
    assert 15180 < large.peak_mb < 1.1 * 15180
    assert 9364 < two.peak_mb < 1.1 * 9364


def test_estimate_in_3d_follows_the_bench():
    """The 3-D coefficients against the peaks of the 3-D bench (the oedometer on N x N x N
    boxes; nodes as the DMPlex check counts them): within 10 %."""
    def hexa(n):
        return resources.estimate("HEXA20", n ** 3, nodes=(n + 1) ** 3 + 3 * n * (n + 1) ** 2)

    def tetra(n, nprocs=1):
        return resources.estimate("TETRA10", 6 * n ** 3, nprocs, nodes=(2 * n + 1) ** 3)

    # HEXA20 N = 24, 32: 3585 and 10316 MB; TETRA10 N = 24: 7452 MB, 5250 MB per process on two
    for est, peak in ((hexa(24), 3585), (hexa(32), 10316), (tetra(24), 7452), (tetra(24, 2), 5250)):
        assert abs(est.peak_mb / peak - 1) < 0.1, (est, peak)
    # MUMPS' factor entries: HEXA20 N = 32 992 million, TETRA10 N = 20 342 million
    assert abs(hexa(32).factor_entries / 992191393 - 1) < 0.05
    assert abs(tetra(20).factor_entries / 342121442 - 1) < 0.05


@pytest.mark.parametrize("cell", ["HEXA20", "TETRA10"])
def test_box_spec_counts_the_nodes_of_the_box(cell):
    from xfemcontact.mesh.generate import box

    class Spec:
        rectangle = None
        refine = 0
        box = {"nx": 3, "ny": 4, "nz": 5, "cell": cell}
    assert preflight.box_nodes(Spec) == len(box(3, 4, 5, cell=cell).points)
    assert preflight.rectangle_cells(Spec) == (cell, 60 * (6 if cell == "TETRA10" else 1))


def test_a_box_that_cannot_fit_is_refused_at_once(tmp_path):
    """A 400 x 400 x 400 HEXA20 box (770 million dofs) stops with one line before the box
    is generated."""
    text = (CASES / "box_hexa20.toml").read_text().replace("nx = 4, ny = 4, nz = 8", "nx = 400, ny = 400, nz = 400")
    assert "nx = 400" in text
    case = write_case(tmp_path, text)
    proc = run_cli(["run", case, "-o", tmp_path / "out"], timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "mesh.box: 64000000 HEXA20 cells" in lines[0]
    assert "-xfc_memory_limit" in lines[0] and "Traceback" not in proc.stderr
    assert not (tmp_path / "out").exists()


def test_rectangle_spec_with_refinement():
    class Spec:
        rectangle = {"nx": 10, "ny": 20, "cell": "TRIA6"}
        refine = 2
    assert preflight.rectangle_cells(Spec) == ("TRIA6", 10 * 20 * 2 * 16)
    Spec.rectangle = None
    assert preflight.rectangle_cells(Spec) is None


def test_a_rectangle_that_cannot_fit_is_refused_at_once(tmp_path):
    case = write_case(tmp_path, with_rectangle(10000))
    proc = run_cli(["run", case, "-o", tmp_path / "out"], timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "mesh.rectangle" in lines[0]
    assert "-xfc_memory_limit" in lines[0] and "Traceback" not in proc.stderr
    assert not (tmp_path / "out").exists()


def test_memory_limit_option(tmp_path):
    case = write_case(tmp_path, with_rectangle(20))
    proc = run_cli(["run", case, "-o", tmp_path / "small", "-xfc_memory_limit", "10"], timeout=120)
    assert proc.returncode == 2 and "10 MB available (-xfc_memory_limit)" in proc.stderr
    proc = run_cli(["run", case, "-o", tmp_path / "off", "-xfc_memory_limit", "0"], timeout=120)
    assert proc.returncode == 0, proc.stderr
    r = results(tmp_path / "off")
    assert r["resources"]["cells"] == 400 and r["resources"]["limit_mb"] is None
    phases = r["memory"]["phases"]
    for name in ("mesh", "layout", "assembly", "solve", "output"):
        rss, peak = phases[name]["rss_mb"][0], phases[name]["peak_mb"][0]
        assert 0 < rss <= peak <= max(r["memory"]["peak_mb_per_process"])
    assert {"output:postmesh", "output:xdmf"} <= set(r["timing_steps"])


def test_rasterise_covers_each_pixel_once():
    # a 10 x 10 square split along a diagonal, in both orientations
    tri = np.array([[[0, 0], [10, 0], [10, 10]], [[0, 0], [0, 10], [10, 10]]], float)
    img = plots.rasterise(tri, np.array([0, 1]), 11, 11)
    assert (img >= 0).all()
    assert (img == 0).sum() + (img == 1).sum() == 121
    outside = plots.rasterise(tri + 20.0, np.array([0, 1]), 11, 11)
    assert (outside == -1).all()


def test_deformed_image_of_a_large_mesh():
    n = 90                                   # 8100 quadrangles: drawn as an image
    xs = np.linspace(0.0, 1.0, n + 1)
    X, Y = np.meshgrid(xs, xs)
    pts = np.c_[X.ravel(), Y.ravel()]
    k = np.arange(n)
    ll = (k[None, :] + (n + 1) * k[:, None]).ravel()
    quads = np.c_[ll, ll + 1, ll + n + 2, ll + n + 1]
    conn = np.c_[quads, quads]               # mid-nodes on the vertices: straight cells
    values = np.linspace(-1.0, 1.0, len(conn))
    pd = {"DX": np.zeros(len(pts)), "DY": np.zeros(len(pts)), "NFISSU": np.zeros(len(pts), int)}
    d = plots.deformed_data(pts, [("quad8", conn)], pd, {"SIYY": [values]})
    assert "image" in d and d["lines"] is not None            # 8 pixels a cell: lines drawn
    img = d["image"]
    inside = ~np.isnan(img)
    assert inside.mean() > 0.99
    assert img[inside].min() >= -1.0 and img[inside].max() <= 1.0
    fig = plots.draw_deformed(d, "test")
    assert "8100 cells drawn as an image" in fig._suptitle.get_text()


def test_plot_helper_that_is_not_running_refuses_jobs(tmp_path):
    from xfemcontact.output.plotter import PlotHelper

    helper = PlotHelper()
    assert not helper.running
    assert helper.send([("plot_x.png", "multipliers_figure", ())], tmp_path) is False
    assert helper.finish() == []


@pytest.mark.parametrize("spare", [True, False])
def test_plots_are_written_with_and_without_the_helper(tmp_path, monkeypatch, spare):
    from xfemcontact.output import plotter

    monkeypatch.setattr(plotter, "spare_core", lambda size: spare)
    case = write_case(tmp_path, SSNV509A)
    code = None
    from xfemcontact.cli import main
    code = main(["run", str(case), "-o", str(tmp_path / "out")])
    assert code == 0
    for name in plots.PLOTS_2D:
        assert (tmp_path / "out" / name).stat().st_size > 10_000
    steps = results(tmp_path / "out")["timing_steps"]
    assert any(k.startswith("plot_helper_cpu:") for k in steps) == spare


def test_plot_helpers_start_before_the_solve_where_a_core_is_spare(tmp_path, monkeypatch):
    """With a spare core the helpers import matplotlib while the run solves, whatever
    its size (the run keeps its peak memory to its end: a helper beside it raises the
    machine's peak as much whenever it starts); two of them, and the run gets every
    plot."""
    from xfemcontact.model import Model
    from xfemcontact.output import folder as folder_module
    from xfemcontact.output import plotter

    monkeypatch.setattr(plotter, "spare_core", lambda size: True)
    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    events = []
    start, solve = folder_module.OutputFolder.start_plot_helper, Model.solve

    def start_helper(self, *args):
        helper = start(self, *args)
        events.append(("helpers", len(helper.procs) if helper is not None else 0))
        return helper

    def solve_model(self, *args, **kwargs):
        events.append(("solve", 0))
        return solve(self, *args, **kwargs)

    monkeypatch.setattr(folder_module.OutputFolder, "start_plot_helper", start_helper)
    monkeypatch.setattr(Model, "solve", solve_model)
    case = write_case(tmp_path, SSNV509A)
    from xfemcontact.cli import main
    assert main(["run", str(case), "-o", str(tmp_path / "out")]) == 0
    assert events[:2] == [("helpers", 2), ("solve", 0)]
    for name in plots.PLOTS_2D:
        assert (tmp_path / "out" / name).stat().st_size > 10_000
    steps = results(tmp_path / "out")["timing_steps"]
    assert {f"plot_helper_cpu:{name}" for name in plots.PLOTS_2D} <= set(steps)


def test_helpers_with_the_outputs_leave_rank_0_its_core(monkeypatch):
    """On two processes of a 2-core machine the helpers start with the outputs, on the
    core of the process that waits: one of them (rank 0 builds the post mesh meanwhile)."""
    from xfemcontact.output.plotter import PlotHelper

    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    assert PlotHelper.start(2).procs == []                      # no core spare, none idle
    helper = PlotHelper.start(2, idle_ranks=1)
    try:
        assert len(helper.procs) == 1
    finally:
        helper.stop()


def test_plot_jobs_are_dealt_to_the_helpers_in_turn(tmp_path, monkeypatch):
    from xfemcontact.output.plotter import PlotHelper

    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    helper = PlotHelper.start(1)
    try:
        assert len(helper.procs) == 2
        jobs = [("plot_a.png", "multipliers_figure", ()), ("plot_b.png", "multipliers_figure", ())]
        assert helper.send(jobs, tmp_path) and helper.send(jobs[:1], tmp_path)
        assert helper.sent == ["plot_a.png", "plot_b.png", "plot_a.png"]
    finally:
        helper.stop()
    assert not helper.running and helper.procs == []


def test_two_helpers_import_in_turn_and_both_draw(tmp_path, monkeypatch):
    """The second helper waits for the first one's import (a pipe it closes), then both
    draw what they were dealt."""
    from xfemcontact.output.plotter import PlotHelper

    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    helper = PlotHelper.start(1)
    assert len(helper.procs) == 2
    record = {"newton_per_solve": [1]}
    jobs = [(f"plot_{k}.png", "convergence_figure", ([1.0, 1e-3], record, k)) for k in "ab"]
    assert helper.send(jobs, tmp_path)
    assert sorted(helper.finish()) == ["plot_a.png", "plot_b.png"]
    assert (tmp_path / "plot_a.png").stat().st_size > 1000 and (tmp_path / "plot_b.png").stat().st_size > 1000
    assert helper.times["import"] > 0 and helper.procs == []


