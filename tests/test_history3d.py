"""Load histories with contact in 3-D: the 2-D machinery (tests/test_history.py) with two
tangential components.

* the validation cases (cases/validation/history_shear3d_hexa20.toml: a Coulomb
  hysteresis whose slip turns from x to y and back along the diagonal;
  history_reclose3d_tetra10.toml: an inclined interface pressed with friction sticking,
  pulled open and reclosed) against their closed forms at every instant, LAGS_F2 too;
  history_turn3d_hexa20.toml (the hysteresis with the slip reversed from +y to -(1, 1) within
  one step) and history_incline_growing3d_tetra10.toml (slip at the Coulomb limit under a
  growing pressure), on which the threshold fixed point does not converge;
* the outputs over time in 3-D: interface.csv with ``inst``, the 3-D columns and
  ``slip_path`` (the length of the vector slip increments), results.json ``steps``,
  plot_history.png;
* the interface surface over time (interface.xdmf + interface.h5, a temporal collection
  beside fields.xdmf): every step's fields at the facets' nodes, those of that step
  (closed forms, interface.csv), the same on 2 processes and after a restart;
* step cutting, a stopped run resumed with other options, a run killed by SIGKILL
  resumed with ``--restart``;
* 2, 3 and 4 processes reproduce one at every instant to 1e-10.
"""
import sys

import numpy as np
import pytest

from conftest import CASES, results, run_cli
from test_history import _kill_after, run_case
from xfemcontact.case import load_case
from xfemcontact.output import interface_csv

VALIDATION = CASES / "validation"
FIELDS = ("LAGS_C", "LAGS_F1", "LAGS_F2", "gap", "slip")


def step_errors(res, case_path, fields=FIELDS):
    """{inst: {field: largest |computed - reference(t)|}} over the interface points of every
    step (the [reference] formulas of x, y, z at each instant)."""
    case = load_case(case_path)
    out = {}
    for step in res["steps"]:
        itf = step["interface"]
        x, y, z = (np.array(itf[c]) for c in ("x", "y", "z"))
        ref = case.reference_at(step["inst"])
        out[step["inst"]] = {f: float(np.abs(np.array(itf[f]) - np.broadcast_to(ref[f](x=x, y=y, z=z), x.shape))
                                      .max()) for f in fields if f in ref}
    return out


def no_plots(case, tmp_path):
    """A copy of ``case`` without plots (the figures take seconds)."""
    path = tmp_path / case.name
    path.write_text(case.read_text().replace("plots = true", "plots = false"))
    return path


@pytest.fixture(scope="module")
def reclose(run_once):
    """history_reclose3d_tetra10.toml writing interface.xdmf, fields.xdmf and the VTU files
    (its plots are off; the output formats do not change what is solved), run once per
    number of processes for every test here that only reads its results: ``reclose(n)`` is
    the CompletedProcess, the results.json and the output folder of ``-q`` on n processes.
    ``reclose.case`` is the case file."""
    text = (VALIDATION / "history_reclose3d_tetra10.toml").read_text()
    assert "formats = []" in text and "plots = false" in text
    case = run_once.case(text.replace("formats = []", 'formats = ["xdmf", "vtu"]'), "history_reclose3d_tetra10.toml")

    def run(n=1):
        p, out = run_once(case, "-q", np_=n if n > 1 else None)
        assert p.returncode == 0, p.stdout + p.stderr
        return p, results(out), out

    run.case = case
    return run


def surface_series(out):
    """The interface surface over time of the output folder ``out`` (meshio's reader of
    interface.xdmf): points ``(n, 3)``, the triangle6 connectivity, and per step
    ``(t, point_data, cell_data)``."""
    import meshio

    reader = meshio.xdmf.TimeSeriesReader(str(out / "interface.xdmf"))
    points, cells = reader.read_points_cells()
    assert [c.type for c in cells] == ["triangle6"]
    return points, cells[0].data, [reader.read_data(k) for k in range(reader.num_steps)]


def test_interface_surface_every_step(reclose):
    """With [instants] in 3-D the interface surface is written at every step
    (interface.xdmf + interface.h5, a temporal collection as fields.xdmf, read back by
    meshio and h5py): each step holds every field of the one-step interface.xdmf, and
    they are that step's: LAGS_C, LAGS_F1, LAGS_F2, gap and slip at the facets' nodes in
    closed form at that instant, LAGS_C and gap within the range of that step's
    interface.csv rows; interface.vtu is the last step."""
    import h5py
    import meshio

    from xfemcontact.contact.problem import SURFACE_FIELDS

    case = reclose.case
    _, res, out = reclose()
    assert {"fields.xdmf", "fields.h5", "interface.xdmf", "interface.h5", "interface.vtu"} <= \
        {p.name for p in out.iterdir()}
    points, conn, frames = surface_series(out)
    insts = [s["inst"] for s in res["steps"]]
    assert [t for t, _, _ in frames] == insts
    expected = set(SURFACE_FIELDS) | {"DX", "DY", "DZ", "displacement", "normal", "t1", "t2"}
    ref = load_case(case)
    table = interface_csv.read(out / "interface.csv")
    x, y, z = points.T
    for t, pd, cd in frames:
        assert set(pd) == expected and set(cd) == {"cell"}, t
        assert all(len(v) == len(points) for v in pd.values()) and len(cd["cell"][0]) == len(conn)
        formulas = ref.reference_at(t)
        for f in FIELDS:
            err = np.abs(pd[f] - np.broadcast_to(formulas[f](x=x, y=y, z=z), x.shape)).max()
            assert err < (1e-9 if f.startswith("LAGS") else 1e-15), (t, f, err)
        rows = table["inst"] == t
        for f, tol in (("LAGS_C", 1e-9), ("gap", 1e-15)):
            lo, hi = table[f][rows].min(), table[f][rows].max()
            assert lo - tol <= pd[f].min() and pd[f].max() <= hi + tol, (t, f)
    assert not any(frames[insts.index(2.0)][1]["contact"]) and all(frames[-1][1]["contact"])
    with h5py.File(out / "interface.h5") as h5:       # written once: the mesh, then each step's
        assert len(h5) == 2 + len(insts) * (len(expected) + 1)
    last = meshio.read(out / "interface.vtu")
    assert np.array_equal(last.points, points)
    for f in expected:
        assert np.array_equal(last.point_data[f], frames[-1][1][f]), f


@pytest.mark.mpi
def test_interface_surface_two_processes(reclose):
    """``mpirun -n 2``: the interface surface over time is the one of one process (the same
    points and facets; every step's fields within 1e-10, LAGS_C relative to its largest)."""
    p1, c1, one = surface_series(reclose(1)[2])
    p2, c2, two = surface_series(reclose(2)[2])
    assert np.array_equal(p1, p2) and np.array_equal(c1, c2) and len(one) == len(two) == 12
    scale = max(np.abs(pd["LAGS_C"]).max() for _, pd, _ in one)
    for (t1, a, ca), (t2, b, cb) in zip(one, two):
        assert t1 == t2 and set(a) == set(b) and np.array_equal(ca["cell"][0], cb["cell"][0])
        for f in a:
            d = np.abs(a[f] - b[f]).max()
            assert d <= 1e-10 * (scale if f in ("LAGS_C", "T") else 1.0), (t1, f, d)


def test_shear_hysteresis_every_instant(tmp_path):
    """The 3-D Coulomb hysteresis: every [[test]] OK; at every instant LAGS_C, LAGS_F1,
    LAGS_F2, gap and slip in closed form; the slip turns from x to y (the tangential
    traction's components in the tangent basis follow), the interface keeps its slip when
    unloaded, slides back to zero along the diagonal; slip_path is the length of the path
    of the slip vector, 4e-4 + 2 sqrt(2) 1e-4 m; interface.csv has one block of rows per
    instant with the 3-D columns; plot_history.png is drawn."""
    case = VALIDATION / "history_shear3d_hexa20.toml"
    out = tmp_path / "out"
    p, res = run_case(case, out)
    assert res["tests"] and all(t["ok"] for t in res["tests"])
    assert [s["inst"] for s in res["steps"]] == [0.5 * k for k in range(1, 17)]
    for t, err in step_errors(res, case).items():
        assert err["LAGS_C"] < 1e-9 and err["gap"] < 1e-15 and err["slip"] < 1e-13, (t, err)
        assert err["LAGS_F1"] < 1e-9 and err["LAGS_F2"] < 1e-9, (t, err)
    by_inst = {s["inst"]: s["interface"] for s in res["steps"]}
    assert np.allclose(by_inst[4.0]["slip1"], 2e-4, rtol=0, atol=1e-15)            # kept on unloading
    assert np.allclose(by_inst[6.0]["slip2"], 2e-4, rtol=0, atol=1e-15)
    assert np.allclose(by_inst[8.0]["slip_path"], 4e-4 + 2 * np.sqrt(2) * 1e-4, rtol=1e-11, atol=0)
    table = interface_csv.read(out / "interface.csv")
    rows = len(res["interface"]["x"])
    assert len(table["inst"]) == 16 * rows
    assert set(interface_csv.COLUMNS_3D) | {"inst", "slip_path", "LAGS_F2_err"} <= set(table)
    assert np.abs(table["LAGS_F2_err"]).max() < 1e-9
    assert (out / "plot_history.png").is_file()
    assert "t = 7.5 (step 15/16)" in p.stdout


@pytest.mark.parametrize("name", ["history_turn3d_hexa20", "history_incline_growing3d_tetra10"])
def test_slip_direction_in_newton_every_instant(tmp_path, name):
    """Histories the threshold fixed point (the slip direction a status) does not converge on:
    the slip turned from +y to -(1, 1) within one step, slip at the Coulomb limit under a
    pressure growing from step to step on an inclined TETRA10 interface.  With Coulomb's law
    in Newton (the slip direction's derivative in the tangent): every [[test]] OK, the closed
    forms at every instant, no cycle guard, at most 40 Newton iterations in all (measured 29
    and 12; the turning step 7)."""
    case = VALIDATION / f"{name}.toml"
    _, res = run_case(case, tmp_path / "out", "-q")
    assert res["tests"] and all(t["ok"] for t in res["tests"])
    assert res["multipliers"]["cycle_guards"] == 0 and res["iterations"]["newton"] <= 40
    for t, err in step_errors(res, case).items():
        assert err["LAGS_C"] < 1e-9 and err["LAGS_F1"] < 1e-10 and err.get("LAGS_F2", 0.0) < 1e-10, (t, err)
        assert err["gap"] < 1e-15 and err["slip"] < 1e-14, (t, err)


def test_reclose_every_instant(reclose):
    """An inclined TETRA10 interface pressed (friction sticking, both tangential
    components of the traction exact), pulled open (gap and slip of the rigid lift,
    tractions zero), pressed again (the reclosing step starts from no slip and sticks)."""
    case = VALIDATION / "history_reclose3d_tetra10.toml"
    _, res, _ = reclose()
    assert res["tests"] and all(t["ok"] for t in res["tests"])
    for t, err in step_errors(res, case).items():
        assert err["LAGS_C"] < 1e-9 and err["LAGS_F1"] < 1e-9 and err["LAGS_F2"] < 1e-9, (t, err)
        assert err["gap"] < 1e-15 and err["slip"] < 1e-15, (t, err)
    opened = {s["inst"]: s["interface"]["contact"] for s in res["steps"]}
    assert not any(opened[2.0]) and all(opened[3.0])


@pytest.mark.slow
def test_step_cutting_stop_and_resume(tmp_path):
    """With the threshold fixed point (-xfc_friction_newton TRESCA) and ITER_FROT_MAXI = 3
    (-friction_snes_max_it) the step 7 -> 7.5 of the hysteresis (the slip starting along the
    diagonal takes 6 threshold iterations there; Coulomb's law in Newton, the default, needs
    no threshold iteration) fails, is cut three times and the run stops (exit code 3) with
    the 14 completed steps and their checkpoints; resumed with --restart and the case's
    limit it ends with the closed form."""
    case = no_plots(VALIDATION / "history_shear3d_hexa20.toml", tmp_path)
    out = tmp_path / "out"
    p = run_cli(["run", case, "-o", out, "-friction_snes_max_it", "3", "-xfc_friction_newton", "TRESCA"])
    assert p.returncode == 3, p.stdout + p.stderr
    assert "cut into 4 steps (level 1 of 3)" in p.stdout
    assert "after 3 cut(s) (subd_niveau = 3)" in p.stderr
    res = results(out)
    assert res["converged"] is False and len(res["steps"]) == 14 and res["steps"][-1]["inst"] == 7.0
    assert (tmp_path / "out.checkpoints" / "manifest.json").is_file()
    p, res = run_case(case, out, "--restart", "-q")
    assert "resumed after step 14 (t = 7)" in p.stdout
    assert res["converged"] and [s["inst"] for s in res["steps"]][-2:] == [7.5, 8.0]
    for t, err in step_errors(res, case).items():
        assert err["LAGS_F1"] < 1e-9 and err["LAGS_F2"] < 1e-9 and err["slip"] < 1e-13, (t, err)
    assert not (tmp_path / "out.checkpoints").exists()


def test_restart_after_sigkill(tmp_path, reclose):
    """A 3-D run killed (SIGKILL) after 5 of its 12 steps resumes with --restart and writes
    the interface.csv, fields.xdmf and interface.xdmf (every step's fields in fields.h5 and
    interface.h5) of the uninterrupted run byte for byte (one process)."""
    import h5py

    case = reclose.case                  # the uninterrupted run: the shared one, same case file
    _, full, full_out = reclose()
    cmd = [sys.executable, "-m", "xfemcontact", "run", case, "-o", tmp_path / "cut", "-q"]
    done = _kill_after(cmd, tmp_path / "cut.checkpoints" / "manifest.json", 5)
    assert 5 <= done < 12 and not (tmp_path / "cut").exists()
    p, resumed = run_case(case, tmp_path / "cut", "--restart", "-q")
    assert f"resumed after step {done}" in p.stdout
    assert (full_out / "interface.csv").read_text() == (tmp_path / "cut" / "interface.csv").read_text()
    assert [s["inst"] for s in resumed["steps"]] == [s["inst"] for s in full["steps"]]
    for name in ("fields", "interface"):
        a, b = full_out / name, tmp_path / "cut" / name
        assert a.with_suffix(".xdmf").read_text() == b.with_suffix(".xdmf").read_text(), name
        with h5py.File(a.with_suffix(".h5")) as ha, h5py.File(b.with_suffix(".h5")) as hb:
            assert sorted(ha) == sorted(hb) and len(ha) > 12, name
            for key in ha:
                assert np.array_equal(ha[key][()], hb[key][()]), (name, key)


@pytest.mark.mpi
@pytest.mark.slow
def test_processes_every_instant(reclose):
    """2, 3 and 4 processes reproduce one at every instant of the reclosing case to 1e-10
    (LAGS_C relative to its largest value; the rest absolute: LAGS_F1, LAGS_F2 and m)."""
    _, one, _ = reclose()
    scale = max(np.abs(s["interface"]["LAGS_C"]).max() for s in one["steps"])
    for n in (2, 3, 4):
        _, many, _ = reclose(n)
        assert all(t["ok"] for t in many["tests"])
        assert [s["inst"] for s in many["steps"]] == [s["inst"] for s in one["steps"]]
        for x, y in zip(one["steps"], many["steps"]):
            for f in FIELDS + ("slip_path",):
                d = np.abs(np.array(x["interface"][f]) - np.array(y["interface"][f])).max()
                assert d <= 1e-10 * (scale if f == "LAGS_C" else 1.0), (n, x["inst"], f, d)
