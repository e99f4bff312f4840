"""``law = "glissiere"``: code_aster's GLISSIERE (bilateral sliding), in 2-D and 3-D.

* SSNV201 A/B rebuilt (cases/validation/ssnv201{a,b}_like_{hexa20,tetra10}.toml): a block
  opened, closed, then pulled and sheared: the contact made at t = 2 is kept at t = 3, in
  tension, while the upper block slides; every [[test]] OK, and the same case with
  ``law = "contact"`` fails its t = 3 tests (the interface reopens);
* 2-D, conditions at the dofs and code_aster's Gauss-point form: the same history;
* friction refused on one line; 2, 3 and 4 processes give the answer of one.
"""
import numpy as np
import pytest

from conftest import CASES, results, run_cli, write_case

VALIDATION = CASES / "validation"
SSNV201 = ["ssnv201a_like_hexa20", "ssnv201a_like_tetra10", "ssnv201b_like_hexa20", "ssnv201b_like_tetra10"]


@pytest.mark.parametrize("name", SSNV201)
def test_ssnv201_cases(run_once, name):
    """Open at t = 1 (gap 1e-3, LAGS_C 0), closed at t = 2 (LAGS_C = -sigma), kept closed
    in tension at t = 3 (LAGS_C = +sigma, gap 0) while sliding (slip 1e-3): every test OK;
    the dofs' statuses at t = 3 are those of t = 2."""
    done, out = run_once(VALIDATION / f"{name}.toml", "-q")     # shared with test_processes
    assert done.returncode == 0, done.stdout + done.stderr
    res = results(out)
    assert len(res["tests"]) == 11 and all(t["ok"] for t in res["tests"])
    steps = {s["inst"]: s for s in res["steps"]}
    assert not any(steps[1.0]["interface"]["contact"]) and all(steps[3.0]["interface"]["contact"])
    assert steps[3.0]["status_changes"] == 0
    assert min(steps[3.0]["interface"]["LAGS_C"]) > 0.99e4            # tension held


def test_contact_law_reopens(tmp_path):
    """The tests of SSNV201 tell the laws apart: with law = "contact" the interface
    reopens at t = 3 (gap = 1.0001e-3, LAGS_C = 0) and the t = 3 tests fail (exit 1)."""
    text = (VALIDATION / "ssnv201a_like_hexa20.toml").read_text().replace('law = "glissiere"', 'law = "contact"')
    done = run_cli(["run", write_case(tmp_path, text), "-o", tmp_path / "out", "-q"])
    assert done.returncode == 1, done.stdout + done.stderr
    res = results(tmp_path / "out")
    failed = {t["name"] for t in res["tests"] if not t["ok"]}
    assert failed == {"kept closed in tension, t = 3: gap", "kept closed in tension, t = 3: LAGS_C",
                      "kept closed in tension, t = 3: DZ"}
    assert np.allclose(res["steps"][-1]["interface"]["gap"], 1.0001e-3, rtol=1e-12)


PLANE = """
title = "2-D GLISSIERE: opened, closed, pulled and sheared"
[mesh]
rectangle = {{ nx = 2, ny = {ny}, x = [0.0, 4.0], y = [0.0, 10.0], cell = "QUAD8" }}
[material]
E = 1.0e8
nu = 0.0
model = "D_PLAN"
[instants]
ranges = [{{ start = 0.0, end = 3.0, steps = 3 }}]
[functions]
vary = {{ vale = [0.0, 0.0, 1.0, 1.0, 2.0, -1.0, 3.0, 1.0] }}
varx = {{ vale = [0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 3.0, 1.0] }}
[[dirichlet]]
group = "LIG1"
DX = 0.0
DY = 0.0
[[dirichlet]]
group = "LIG3"
DY = 1.0e-3
fonc_mult = "vary"
[[dirichlet]]
group = "LIG3"
DX = 1.0e-3
fonc_mult = "varx"
[interface]
level_set = "y - 5"
law = "glissiere"
[contact]
contact_init = "NON"
integration = "{integration}"
[output]
formats = []
plots = false
"""


@pytest.mark.parametrize("integration", ["NOEUD", "GAUSS"])
@pytest.mark.parametrize("ny", [4, 5])
def test_plane(tmp_path, integration, ny):
    """2-D, the interface along cell edges (ny = 4) or through cells (ny = 5), conditions
    at the dofs or at the Gauss points: open (gap 1e-3), closed (LAGS_C = -1e4 Pa), kept
    closed in tension (LAGS_C = +1e4 Pa, gap 0) while the upper part slides by 1e-3 m."""
    out = tmp_path / "out"
    done = run_cli(["run", write_case(tmp_path, PLANE.format(ny=ny, integration=integration)), "-o", out, "-q"])
    assert done.returncode == 0, done.stdout + done.stderr
    itf = {s["inst"]: s["interface"] for s in results(out)["steps"]}
    assert np.allclose(itf[1.0]["gap"], 1e-3, rtol=0, atol=1e-15) and np.allclose(itf[1.0]["LAGS_C"], 0.0)
    assert np.allclose(itf[2.0]["gap"], 0.0, atol=1e-15) and np.allclose(itf[2.0]["LAGS_C"], -1e4, rtol=1e-9)
    assert np.allclose(itf[3.0]["gap"], 0.0, atol=1e-15) and np.allclose(itf[3.0]["LAGS_C"], 1e4, rtol=1e-9)
    assert np.allclose(np.abs(itf[3.0]["slip"]), 1e-3, rtol=1e-12)


def test_friction_refused(tmp_path):
    """GLISSIERE is frictionless: frottement = "COULOMB" is refused on one line, exit 2."""
    text = (VALIDATION / "ssnv201a_like_hexa20.toml").read_text().replace(
        "[contact]\n", '[contact]\nfrottement = "COULOMB"\ncoulomb = 0.3\n')
    done = run_cli(["run", write_case(tmp_path, text), "-o", tmp_path / "out"])
    assert done.returncode == 2
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "contact.frottement" in lines[0] and "frictionless" in lines[0], done.stderr


@pytest.mark.mpi
@pytest.mark.slow
def test_processes(run_once):
    """2, 3 and 4 processes reproduce one process at every instant to 1e-10 (a process
    without interface elements included: the box has 60 cells)."""
    case = VALIDATION / "ssnv201a_like_tetra10.toml"
    runs = {}
    for n in (None, 2, 3, 4):              # one process: the run of test_ssnv201_cases
        done, out = run_once(case, "-q", np_=n)
        assert done.returncode == 0, done.stdout + done.stderr
        runs[n or 1] = results(out)
    for n in (2, 3, 4):
        for x, y in zip(runs[1]["steps"], runs[n]["steps"]):
            assert x["inst"] == y["inst"]
            for f, scale in (("LAGS_C", 1e4), ("gap", 1.0), ("slip", 1.0)):
                d = np.abs(np.array(x["interface"][f]) - np.array(y["interface"][f])).max()
                assert d <= 1e-10 * scale, (n, x["inst"], f, d)
