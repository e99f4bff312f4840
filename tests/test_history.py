"""Load histories: instants and functions of time in case files, load steps with history
in the contact law, step cutting, checkpoints and restart, results over time.

The validation cases (cases/validation/history_*.toml, ssnv182f_like.toml,
ssnv509_ramp.toml) have closed forms at every instant; they are checked here at
every instant, not only at the instants of their [[test]] tables.
"""
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import CASES, ENV, ROOT, results, run_cli, write_case
from xfemcontact.case import load_case
from xfemcontact.case.functions import Function
from xfemcontact.errors import XfcError
from xfemcontact.output import interface_csv

VALIDATION = CASES / "validation"

BASE = """
title = "history"
[mesh]
rectangle = { nx = 4, ny = 4, x = [0.0, 2.0], y = [0.0, 2.0] }
[material]
E = 1.0e6
nu = 0.0
[[dirichlet]]
group = "LIG1"
DX = 0.0
DY = 0.0
[[dirichlet]]
group = "LIG3"
DX = 0.0
DY = "-1e-4*t"
"""


# --- case files ---------------------------------------------------------------------------

def test_function_extensions():
    f = Function("f", (0.0, 1.0, 3.0), (0.0, 2.0, -2.0), "CONSTANT", "LINEAIRE")
    assert f(0.5) == 1.0 and f(1.0) == 2.0 and f(2.0) == 0.0
    assert f(-1.0) == 0.0                       # CONSTANT on the left
    assert f(4.0) == -4.0                       # LINEAIRE on the right: slope -2
    g = Function("g", (0.0, 1.0), (1.0, 3.0))
    with pytest.raises(ValueError, match="prol_droite"):
        g(1.5)
    assert g.outside([0.0, 0.5, 1.0]) is None and g.outside([0.0, 2.0]) == 2.0


def test_instants_and_functions_loaded(tmp_path):
    case = load_case(write_case(tmp_path, BASE + """
[instants]
values = [0.0, 0.25]
ranges = [{ start = 0.5, end = 1.0, steps = 2 }, { start = 1.0, end = 2.0, steps = 1 }]
echec = { subd_pas = 3, subd_niveau = 2 }
[functions]
ramp = { vale_para = [0.0, 1.0], vale_fonc = [0.0, 1.0], prol_droite = "CONSTANT" }
[[traction]]
group = "LIG2"
FX = "2*t"
fonc_mult = "ramp"
[[test]]
field = "DY"
type = "MIN"
reference = -1e-4
tolerance = 1e-6
inst = 0.75
"""))
    assert case.instants.values == (0.0, 0.25, 0.5, 0.75, 1.0, 2.0)
    assert (case.instants.action, case.instants.subd_pas, case.instants.subd_niveau) == ("DECOUPE", 3, 2)
    fx = case.traction[0].force["FX"]
    assert float(fx(x=0.0, y=1.0)) == 4.0                     # at the last instant: 2 t * ramp(2) = 4
    assert float(fx.at(0.5)(x=0.0, y=1.0)) == 0.5
    assert case.tests[0].inst == 0.75
    assert float(case.dirichlet[1].components["DY"].at(0.5)(x=1.0, y=2.0)) == -0.5e-4


def test_case_without_instants_is_one_step(tmp_path):
    case = load_case(write_case(tmp_path, BASE))
    assert case.instants.values == (0.0, 1.0) and not case.instants.given
    assert float(case.dirichlet[1].components["DY"](x=1.0, y=2.0)) == -1e-4


def test_readme_example_loads(tmp_path):
    """The complete example of README.md (Load histories) is a valid case."""
    text = (ROOT / "README.md").read_text()
    section = text[text.index("## Load histories"):text.index("## When something goes wrong")]
    example = re.search(r"```toml\n(.*?)```", section, re.S).group(1)
    case = load_case(write_case(tmp_path, example))
    assert len(case.instants.values) == 15 and set(case.functions) == {"press", "tau", "shear"}
    assert case.functions["shear"](8.0) == 0.0 and case.tests[0].inst == 4.0


@pytest.mark.parametrize("extra, message", [
    ("[instants]\nvalues = [0.0, 1.0, 0.5]", r"instants.values\[2\]: instants must increase"),
    ("[instants]\nranges = [{ start = 1.0, end = 1.0, steps = 2 }]", r"instants.ranges\[0\].end: must be > start"),
    ("[instants]\nvalues = [1.0]", r"instants: give at least two instants"),
    ("[instants]\nranges = [{ start = 0.0, end = 1.0 }]", r"instants.ranges\[0\].steps: missing required key"),
    ("[instants]\nvalues = [0.0, 1.0]\necheck = {}", r"instants.echeck: unknown key \(did you mean 'echec'\?\)"),
    ("[instants]\nvalues = [0.0, 1.0]\n[instants.echec]\nsubd_pas = 1", r"instants.echec.subd_pas: must be >= 2"),
    ("[instants]\nvalues = [0.0, 1.0]\n[instants.echec]\naction = \"STOP\"", r"instants.echec.action: unknown value"),
    ("[functions]\nf = { vale = [0.0, 1.0, 2.0] }", r"functions.f.vale: expected pairs"),
    ("[functions]\nf = { vale = [1.0, 0.0, 0.0, 1.0] }", r"functions.f.vale: the abscissae must increase"),
    ("[functions]\nf = { vale_para = [0.0, 1.0] }", r"functions.f.vale_fonc: required with vale_para"),
    ("[functions]\nf = { vale = [0.0, 1.0], vale_para = [0.0] }", r"functions.f: give either 'vale' or"),
    ("[functions]\nsin = { vale = [0.0, 1.0] }", r"functions.sin: 'sin' is a function"),
    ("[functions]\nf = { vale = [0.0, 0.0, 0.5, 1.0] }\n[[traction]]\ngroup = \"LIG2\"\nFX = 1.0\nfonc_mult = \"f\"",
     r"traction\[0\].fonc_mult: function \"f\" has no value at instant 1"),
    ("[[traction]]\ngroup = \"LIG2\"\nFX = 1.0\nfonc_mult = \"g\"", r"traction\[0\].fonc_mult: no function \"g\" in \[functions\]"),
    ("[parameters]\nt = 1.0", r"parameters.t: 't' is a formula variable \(the instant\)"),
    ("[[test]]\nfield = \"DY\"\ntype = \"MIN\"\nreference = 1.0\ntolerance = 1.0\ninst = 0.5",
     r"test\[0\].inst: 0.5 is not an instant of the case \(instants: 0, 1\)"),
    ("[interface]\nlevel_set = \"y - t\"", r"interface.level_set: unknown name 't'"),
])
def test_bad_history_keys(tmp_path, extra, message):
    with pytest.raises(XfcError, match=message) as info:
        load_case(write_case(tmp_path, BASE + extra))
    assert "\n" not in str(info.value)


# --- runs -----------------------------------------------------------------------------------

def run_case(case, out, *args, np_=None, code=0):
    p = run_cli(["run", case, "-o", out, *args], np=np_)
    assert p.returncode == code, p.stdout + p.stderr
    return p, results(out)


def run_shared(run_once, case, *args, np_=None):
    """``run_case`` of a run several tests only read, done once per session (conftest.Runs)."""
    p, out = run_once(case, *args, np_=np_)
    assert p.returncode == 0, p.stdout + p.stderr
    return p, results(out), out


#: the one-process runs the tests of each history case read (test_mpi_every_instant compares
#: the same ones with 2 and 3 processes; -q changes the progress lines only)
ONE_PROCESS = {"history_shear_cycle": (), "history_open_reclose": ("-q",), "history_cut": ()}


def step_errors(res, case_path, fields=("LAGS_C", "LAGS_F1", "slip", "gap")):
    """{inst: {field: largest |computed - reference(t)|}} over the interface points of
    every step (the [reference] formulas of the case, at each instant)."""
    case = load_case(case_path)
    out = {}
    for step in res["steps"]:
        itf = step["interface"]
        x, y = np.array(itf["x"]), np.array(itf["y"])
        ref = case.reference_at(step["inst"])
        out[step["inst"]] = {f: float(np.abs(np.array(itf[f]) - np.broadcast_to(ref[f](x=x, y=y), x.shape)).max())
                             for f in fields if f in ref}
    return out


def hysteresis(t):
    """tau (Pa) and slip s (m) of history_shear_cycle.toml at instant t."""
    c = lambda u, a: min(max(u, 0.0), a)            # noqa: E731
    tau = 50.0 * (c(t - 1, 1) - c(t - 3, 2) + c(t - 6, 1))
    s = 2e-4 * (c(t - 2, 1) - c(t - 5, 1))
    return tau, s


def test_shear_cycle_every_instant(run_once):
    """Coulomb hysteresis in closed form at each of the 14 instants: stick, slip, stick on
    unloading with the slip kept, reverse slip; the accumulated slip; the output files."""
    case = VALIDATION / "history_shear_cycle.toml"
    p, res, out = run_shared(run_once, case, *ONE_PROCESS["history_shear_cycle"])
    steps = res["steps"]
    assert [s["inst"] for s in steps] == [0.5 * k for k in range(1, 15)]
    assert len(re.findall(r"^t = .*Newton iteration", p.stdout, re.M)) == 14
    for step in steps:
        tau, s = hysteresis(step["inst"])
        itf = step["interface"]
        p_ = 100.0 * min(step["inst"], 1.0)
        assert np.allclose(itf["LAGS_C"], -p_, rtol=0, atol=1e-9)
        assert np.allclose(itf["LAGS_F1"], -tau / (0.5 * p_) if p_ else 0.0, rtol=0, atol=1e-9)
        assert np.allclose(itf["slip"], s, rtol=0, atol=1e-15)
        assert np.allclose(itf["gap"], 0.0, atol=1e-15)
    assert np.allclose(steps[-1]["interface"]["slip_path"], 4e-4, atol=1e-15)      # there and back
    assert all(t["ok"] for t in res["tests"]) and {t["inst"] for t in res["tests"]} == {1.5, 3.0, 4.0, 5.5, 7.0}
    # interface.csv: one block per instant; fields.xdmf: one frame per instant
    cols = interface_csv.read(out / "interface.csv")
    assert list(np.unique(cols["inst"])) == [s["inst"] for s in steps]
    assert "slip_path" in cols and "slip_err" in cols
    xdmf = (out / "fields.xdmf").read_text()
    assert xdmf.count("<Time Value=") == 14 and 'CollectionType="Temporal"' in xdmf
    assert (out / "plot_history.png").is_file()
    assert not out.with_name("out.checkpoints").exists()        # removed once the results are in


def test_open_reclose_every_instant(run_once):
    case = VALIDATION / "history_open_reclose.toml"
    p, res, _ = run_shared(run_once, case, *ONE_PROCESS["history_open_reclose"])
    assert ONE_PROCESS["history_open_reclose"] == ("-q",)
    assert not re.search(r"^t = ", p.stdout, re.M)              # -q: no progress lines
    errors = step_errors(res, case)
    assert len(errors) == 12
    for t, e in errors.items():
        assert e["LAGS_C"] < 1e-9 and e["gap"] < 1e-15 and e["slip"] < 1e-15, (t, e)
    opened = [s["inst"] for s in res["steps"] if max(s["interface"]["gap"]) > 1e-6]
    assert opened == [1.75, 2.0, 2.25]


def test_ssnv182f_two_steps(tmp_path):
    _, res = run_case(VALIDATION / "ssnv182f_like.toml", tmp_path / "out")
    assert [s["inst"] for s in res["steps"]] == [1.0, 2.0]
    assert all(t["ok"] for t in res["tests"]) and len(res["tests"]) == 12
    for s in res["steps"]:
        assert np.allclose(s["interface"]["LAGS_C"], -0.0375, rtol=1e-10)
        assert np.allclose(s["interface"]["LAGS_F1"], -np.tan(np.pi / 6), rtol=1e-10)


def test_ssnv509_ramp_gives_the_one_step_answer(tmp_path, run_once):
    """SSNV509 a in 4 steps (stick everywhere: path-independent) ends at the one-step
    answer; a case without [instants] runs as one step with a one-entry steps list."""
    _, ramp = run_case(VALIDATION / "ssnv509_ramp.toml", tmp_path / "ramp")
    _, one, _ = run_shared(run_once, CASES / "ssnv509a.toml")
    assert len(ramp["steps"]) == 4 and len(one["steps"]) == 1 and one["steps"][0]["inst"] == 1.0
    for f in ("LAGS_C", "LAGS_F1"):
        assert np.abs(np.array(ramp["interface"][f]) - np.array(one["interface"][f])).max() < 1e-10
    for t, e in step_errors(ramp, VALIDATION / "ssnv509_ramp.toml", ("LAGS_C", "LAGS_F1")).items():
        assert e["LAGS_C"] < 2e-6 * t and e["LAGS_F1"] < 2e-5, (t, e)


def test_step_cutting(tmp_path, run_once):
    """The step 3 -> 6 fails at full size (more than the 3 Newton iterations allowed) and
    converges cut into 4; with 2 iterations allowed the run stops (exit 3) after two
    levels, keeping the completed steps and their checkpoints, and --restart with 3
    iterations allowed ends the run."""
    case = VALIDATION / "history_cut.toml"
    # the default (the line search; the stick branch at a step's start, the elastic predictor)
    # turns the shear within the 3 iterations at full size
    _, res, _ = run_shared(run_once, case, *ONE_PROCESS["history_cut"])
    assert [(s["inst"], s["level"]) for s in res["steps"]] == [(1.0, 0), (3.0, 0), (6.0, 0), (7.0, 0)]
    for step in res["steps"]:
        tau, s = hysteresis(step["inst"])
        assert np.allclose(step["interface"]["slip"], s, rtol=0, atol=1e-15)
    # full steps do not: the step is cut into 4
    p, res, _ = run_shared(run_once, case, "-xfc_friction_line_search", "NONE")
    assert [(s["inst"], s["level"]) for s in res["steps"]] == [
        (1.0, 0), (3.0, 0), (3.75, 1), (4.5, 1), (5.25, 1), (6.0, 1), (7.0, 0)]
    assert "cut into 4 steps (level 1 of 2)" in p.stdout
    for step in res["steps"]:
        tau, s = hysteresis(step["inst"])
        assert np.allclose(step["interface"]["slip"], s, rtol=0, atol=1e-15)
        assert np.allclose(step["interface"]["LAGS_F1"], -tau / 50.0, rtol=0, atol=1e-9)
    out = tmp_path / "fail"
    p = run_cli(["run", case, "-o", out, "-snes_max_it", "2"])
    assert p.returncode == 3, p.stdout + p.stderr
    assert "no convergence at t = 2.125 (step from t = 2) after 2 cut(s)" in p.stderr
    res = results(out)
    assert res["converged"] is False and [s["inst"] for s in res["steps"]] == [1.0, 1.5, 2.0]
    assert res["diagnostics"]["failed_step"]["level"] == 2
    assert (tmp_path / "fail.checkpoints" / "manifest.json").is_file()
    assert "3 completed step(s) checkpointed" in p.stdout
    p, res = run_case(case, out, "--restart", "-snes_max_it", "3")
    assert "resumed after step 3 (t = 2)" in p.stdout
    assert res["converged"] and res["steps"][-1]["inst"] == 7.0
    assert np.allclose(res["steps"][-1]["interface"]["slip"], 0.0, atol=1e-15)
    assert not (tmp_path / "fail.checkpoints").exists()


def test_restart_refused(tmp_path):
    case = VALIDATION / "history_cut.toml"
    p = run_cli(["run", case, "-o", tmp_path / "none", "--restart"])
    assert p.returncode == 2 and p.stderr.strip().count("\n") == 0
    assert "nothing to restart from" in p.stderr
    p = run_cli(["run", CASES / "ssnv509a.toml", "-o", tmp_path / "one", "--restart"])
    assert p.returncode == 2 and "the case has no [instants]" in p.stderr
    # checkpoints of a failed run: a run without --restart refuses them, a changed case too
    text = case.read_text()
    copy = tmp_path / "c.toml"
    copy.write_text(text)
    assert run_cli(["run", copy, "-o", tmp_path / "f", "-snes_max_it", "1"]).returncode == 3
    shutil.rmtree(tmp_path / "f")             # as a killed run leaves it: checkpoints only
    p = run_cli(["run", copy, "-o", tmp_path / "f"])
    assert p.returncode == 2 and "checkpoints of an earlier run" in p.stderr
    copy.write_text(text.replace("iter_glob_maxi = 3", "iter_glob_maxi = 4"))
    p = run_cli(["run", copy, "-o", tmp_path / "f", "--restart"])
    assert p.returncode == 2 and "the case file changed since the checkpoints were written" in p.stderr
    assert p.stderr.strip().count("\n") == 0


def _kill_after(cmd, manifest, completed, timeout=120):
    """Run ``cmd``, SIGKILL it and all its children once ``manifest`` says ``completed``
    steps; returns the number of completed steps when it was killed."""
    proc = subprocess.Popen([str(c) for c in cmd], start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=ENV, cwd=ROOT)
    end = time.monotonic() + timeout
    done = 0
    while proc.poll() is None and time.monotonic() < end:
        try:
            done = json.loads(manifest.read_text())["completed"]
        except (OSError, ValueError, KeyError):
            done = 0
        if done >= completed:
            for pid in _tree(proc.pid):
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            break
        time.sleep(0.002)
    proc.wait()
    return done


def _tree(pid):
    children = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                ppid = int(open(f"/proc/{d}/stat").read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(d))
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo += children.get(p, [])
    return out


def _long_cycle(tmp_path):
    """history_shear_cycle on 16 x 16 cells and 38 steps (a few seconds)."""
    text = (VALIDATION / "history_shear_cycle.toml").read_text()
    text = text.replace("nx = 8, ny = 8", "nx = 16, ny = 16").replace("steps = 12 }", "steps = 36 }")
    path = tmp_path / "long.toml"
    path.write_text(text)
    return path


def _same_steps(a, b):
    assert [s["inst"] for s in a["steps"]] == [s["inst"] for s in b["steps"]]
    for x, y in zip(a["steps"], b["steps"]):
        for f in ("LAGS_C", "LAGS_F1", "gap", "slip", "slip_path", "contact", "sliding"):
            assert np.abs(np.array(x["interface"][f]) - np.array(y["interface"][f])).max(initial=0) <= \
                1e-12 * max(1.0, np.abs(x["interface"][f]).max(initial=0)), f


@pytest.mark.slow
@pytest.mark.parametrize("np_", [None, pytest.param(2, marks=pytest.mark.mpi)])
def test_restart_after_sigkill(tmp_path, np_):
    """A run killed (SIGKILL, every process) after some steps resumes with --restart and
    ends with the results of the uninterrupted run."""
    case = _long_cycle(tmp_path)
    _, full = run_case(case, tmp_path / "full", "-q", np_=np_)
    cmd = [sys.executable, "-m", "xfemcontact", "run", case, "-o", tmp_path / "cut", "-q"]
    if np_:
        cmd = ["mpirun", "-n", str(np_), "--oversubscribe"] + cmd
    done = _kill_after(cmd, tmp_path / "cut.checkpoints" / "manifest.json", 12)
    assert 12 <= done < 38 and not (tmp_path / "cut").exists()
    p, resumed = run_case(case, tmp_path / "cut", "--restart", "-q", np_=np_)
    assert f"resumed after step {done}" in p.stdout
    _same_steps(full, resumed)
    if not np_:        # one process: byte for byte (two runs of 2 processes differ at round-off)
        a = (tmp_path / "full" / "interface.csv").read_text()
        assert a == (tmp_path / "cut" / "interface.csv").read_text()


@pytest.mark.slow
def test_coefficients_do_not_matter(tmp_path, run_once):
    """The cycle with COEF_CONT and COEF_FROT far from their defaults: the same answers."""
    text = (VALIDATION / "history_shear_cycle.toml").read_text()
    _, ref, _ = run_shared(run_once, VALIDATION / "history_shear_cycle.toml", *ONE_PROCESS["history_shear_cycle"])
    for keys in ("coef_cont = 100.0\ncoef_frot = 1.0", "coef_cont = 1.0e12\ncoef_frot = 1.0e9"):
        path = tmp_path / "c.toml"
        path.write_text(text.replace("coulomb = 0.5\n", f"coulomb = 0.5\n{keys}\n"))
        _, res = run_case(path, tmp_path / "c", "-q", "--overwrite")
        for x, y in zip(ref["steps"], res["steps"]):
            for f, tol in (("LAGS_C", 1e-9), ("LAGS_F1", 1e-9), ("slip", 1e-15)):
                assert np.abs(np.array(x["interface"][f]) - np.array(y["interface"][f])).max() < tol, (keys, f)


@pytest.mark.slow
def test_gauss_formulation_history(tmp_path):
    """integration = "GAUSS" carries its history too: the cycle in closed form."""
    text = (VALIDATION / "history_shear_cycle.toml").read_text()
    path = tmp_path / "g.toml"
    path.write_text(text.replace("[contact]\n", "[contact]\nintegration = \"GAUSS\"\n"))
    _, res = run_case(path, tmp_path / "g", "-q")
    for step in res["steps"]:
        tau, s = hysteresis(step["inst"])
        p_ = 100.0 * min(step["inst"], 1.0)
        assert np.allclose(step["interface"]["slip"], s, rtol=0, atol=1e-14)
        assert np.allclose(step["interface"]["LAGS_F1"], -tau / (0.5 * p_) if p_ else 0.0, atol=1e-8)


@pytest.mark.mpi
@pytest.mark.parametrize("name", ["history_shear_cycle", "history_open_reclose", "history_cut"])
def test_mpi_every_instant(tmp_path, run_once, name):
    """2 and 3 processes reproduce one process at every instant to 1e-10."""
    case = VALIDATION / f"{name}.toml"
    _, one, _ = run_shared(run_once, case, *ONE_PROCESS[name])
    for n in (2, 3):
        _, many = run_case(case, tmp_path / str(n), "-q", np_=n)
        assert [s["inst"] for s in many["steps"]] == [s["inst"] for s in one["steps"]]
        for x, y in zip(one["steps"], many["steps"]):
            for f in ("LAGS_C", "LAGS_F1", "gap", "slip"):
                assert np.abs(np.array(x["interface"][f]) - np.array(y["interface"][f])).max() < 1e-10, (n, f)
