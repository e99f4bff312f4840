"""code_aster's SSNV195 C rebuilt (SPEC.md section 7): a bar with two inclined interfaces
and its middle face clamped, one half compressed, the other pulled.  With the middle face
clamped the halves do not interact, so each is its own single-interface case
(cases/validation/ssnv195c_{lower,upper}_like_{hexa20,tetra10}.toml):

* lower half: stick across the interface inclined at 30 degrees, LAGS_C = -1.2e4 / (1 +
  s^2) = -9000.002 Pa (code_aster: -9e3 to 1e-6), LAGS_F1 = 0, LAGS_F2 = s = 0.57735, the
  tangential traction's magnitude s |LAGS_C|; DZ linear, no jump;
* upper half: the interface opens, the block above it lifted rigidly by 3e-3 m: DZ = 3e-3
  above, 0 below, LAGS_C = 0, gap 3e-3 / sqrt(1 + s^2), tangential jump s times that.

Every [[test]] of the cases OK, the interface table against the closed forms, 1 and 3
processes."""
import numpy as np
import pytest

from conftest import CASES, results, run_cli
from xfemcontact.output import interface_csv

S = 0.57735
NZ = 1.0 / np.sqrt(1.0 + S * S)
CASE = CASES / "validation" / "ssnv195c_{}_like_{}.toml"


def solve(tmp_path, half, cell, np_=None):
    out = tmp_path / f"{half}_{cell}_{np_}"
    done = run_cli(["run", str(CASE).format(half, cell), "-o", out, "-q", "-mat_mumps_icntl_24", "1"], np=np_)
    assert done.returncode == 0, done.stdout + done.stderr
    res = results(out)
    assert res["tests"] and all(t["ok"] for t in res["tests"])
    assert res["linear_solver"]["mumps"]["null_pivots"] == 0
    return res, interface_csv.read(out / "interface.csv")


@pytest.mark.parametrize("cell", ["hexa20", "tetra10"])
def test_lower_half_sticks(tmp_path, cell):
    res, t = solve(tmp_path, "lower", cell)
    lam = -1.2e4 * NZ ** 2
    assert len(t["x"]) > 0 and np.all(t["contact"] == 1) and not np.any(t["sliding"])
    assert np.abs(t["LAGS_C"] / lam - 1.0).max() < 1e-10
    assert np.abs(t["LAGS_F1"]).max() < 1e-10
    assert np.abs(t["LAGS_F2"] - S).max() < 1e-10
    assert np.abs(t["T"] - S * abs(lam)).max() < 1e-10 * abs(lam)
    assert np.abs(t["gap"]).max() < 1e-15 and np.abs(t["slip"]).max() < 1e-15
    assert res["iterations"]["newton"] == 1


@pytest.mark.parametrize("cell", ["hexa20", "tetra10"])
def test_upper_half_opens(tmp_path, cell):
    res, t = solve(tmp_path, "upper", cell)
    assert len(t["x"]) > 0 and not np.any(t["contact"])
    assert np.abs(t["LAGS_C"]).max() < 1e-10
    assert np.abs(t["gap"] - 3e-3 * NZ).max() < 1e-15
    assert np.abs(t["slip"] - 3e-3 * S * NZ).max() < 1e-15
    assert res["iterations"]["newton"] <= 2


@pytest.mark.mpi
def test_three_processes(tmp_path):
    """3 processes give one process's interface table to 1e-10 (the lower half, HEXA20)."""
    _, one = solve(tmp_path, "lower", "hexa20")
    _, three = solve(tmp_path, "lower", "hexa20", np_=3)
    order1 = np.lexsort((one["z"], one["y"], one["x"]))
    order3 = np.lexsort((three["z"], three["y"], three["x"]))
    for field in ("LAGS_C", "LAGS_F1", "LAGS_F2", "T"):
        scale = 9e3 if field in ("LAGS_C", "T") else 1.0
        assert np.abs(one[field][order1] - three[field][order3]).max() < 1e-10 * scale, field
