"""code_aster's 3-D analytical X-FEM contact tests rebuilt (SPEC.md section 7), one step:

* SSNV182 A, B, C-like (cases/validation/ssnv182{a,b,c}_like_{hexa20,tetra10}.toml): the
  5 x 20 x 20 block of code_aster's mesh compressed across a horizontal interface (A:
  along cell faces; C: through a layer of cells) or an inclined one (B, slope -1/2),
  Coulomb with mu = 1: LAGS_C = -5 / -4, LAGS_F1 = 0, LAGS_F2 = 0 / -0.5 at every
  interface point to 1e-10 (B: the tangent basis t1 = e_x, t2 = n x t1 is code_aster's
  on this plane, and its LAGS_F2 sign is reproduced);
* SSNV186 E-like (ssnv186e_like_{hexa20,tetra10,jittered_tetra10}.toml): a uniform
  pressure of 1e7 Pa across z = 17.5, on box meshes and on an unstructured (jittered,
  Delaunay) TETRA10 mesh: LAGS_C = -1e7 Pa to 1e-10;
* 2, 3 and 4 processes give the interface values of one to 1e-10 (coarser copies of the
  blocks: the closed forms hold on any mesh; SSNV182's are coarser in the tests as well,
  the case files at code_aster's size run in 4 - 10 s each).

(SSNV201, GLISSIERE: tests/test_glissiere.py; load histories: tests/test_history3d.py.)
"""
import re

import numpy as np
import pytest

from conftest import CASES, results, write_case
from xfemcontact.output import interface_csv

VALIDATION = CASES / "validation"
CASE_NAMES = [f"ssnv182{v}_like_{c}" for v in "abc" for c in ("hexa20", "tetra10")] + \
    [f"ssnv186e_like_{m}" for m in ("hexa20", "tetra10", "jittered_tetra10")]
#: SSNV182 on 1 x 10 x 10 (C: 1 x 10 x 9) cells instead of code_aster's 5 x 20 x 20 (19):
#: the same interface positions (A on a plane of vertices, B through vertices and mid-edge
#: nodes, C through the middle of a layer) in 1 - 2 s instead of 4 - 10 s (the case files
#: themselves: cases/validation/validation3d_table.py, README)
COARSE = {"ssnv182a": "box = {nx = 1, ny = 10, nz = 10,", "ssnv182b": "box = {nx = 1, ny = 10, nz = 10,",
          "ssnv182c": "box = {nx = 1, ny = 10, nz = 9,"}
#: (LAGS_C, LAGS_F2) of each closed form
EXACT = {"ssnv182a": (-5.0, 0.0), "ssnv182b": (-4.0, -0.5), "ssnv182c": (-5.0, 0.0), "ssnv186e": (-1e7, 0.0)}


@pytest.mark.parametrize("name", CASE_NAMES)
def test_case(tmp_path, run_once, name):
    """Every [[test]] OK (MIN and MAX of LAGS_C, LAGS_F1, LAGS_F2 as code_aster tests them,
    and the gap); at every interface point of interface.csv LAGS_C, LAGS_F1, LAGS_F2 and
    the tangential traction's magnitude T (basis-free) are the closed form's to 1e-10
    (SSNV182 on the coarser blocks of COARSE)."""
    box = COARSE.get(name[:8])
    done, out = run_once(coarse(name, tmp_path, box) if box else VALIDATION / f"{name}.toml", "-q")
    assert done.returncode == 0, done.stdout + done.stderr
    res = results(out)
    assert res["tests"] and all(t["ok"] for t in res["tests"])
    lam, f2 = EXACT[name[:8]]
    table = interface_csv.read(out / "interface.csv")
    assert len(table["x"]) > 0 and np.all(table["contact"] == 1)
    assert np.abs(table["LAGS_C"] / lam - 1.0).max() < 1e-10
    assert np.abs(table["LAGS_F1"]).max() < 1e-10
    assert np.abs(table["LAGS_F2"] - f2).max() < 1e-10
    assert np.abs(table["T"] - abs(f2 * lam)).max() < 1e-10 * abs(lam)
    assert res["iterations"]["newton"] <= 2


def coarse(name, tmp_path, box):
    """A copy of a case with another ``mesh.box`` (the closed forms hold on any mesh)."""
    text = (VALIDATION / f"{name}.toml").read_text()
    text, n = re.subn(r"box = \{nx = \d+, ny = \d+, nz = \d+,", box, text)
    assert n == 1
    return write_case(tmp_path, text, f"{name}.toml")


@pytest.mark.mpi
@pytest.mark.slow
@pytest.mark.parametrize("name, box", [
    ("ssnv182b_like_hexa20", "box = {nx = 1, ny = 4, nz = 4,"),
    ("ssnv182b_like_tetra10", "box = {nx = 1, ny = 4, nz = 4,"),
    ("ssnv186e_like_jittered_tetra10", None)])
def test_processes(tmp_path, run_once, name, box):
    """``mpirun -n 2``, ``-n 3`` and ``-n 4`` reproduce one process's interface table to
    1e-10 (LAGS_C relative to its value, LAGS_F1, LAGS_F2 absolute, gap and slip in m),
    every test OK."""
    case = coarse(name, tmp_path, box) if box else VALIDATION / f"{name}.toml"
    tables = {}
    for n in (None, 2, 3, 4):              # one process, ssnv186e: the run of test_case
        done, out = run_once(case, "-q", np_=n)
        assert done.returncode == 0, done.stdout + done.stderr
        assert all(t["ok"] for t in results(out)["tests"])
        tables[n or 1] = interface_csv.read(out / "interface.csv")
    one = tables[1]
    scale = np.abs(one["LAGS_C"]).max()
    for n in (2, 3, 4):
        other = tables[n]
        assert np.array_equal(one["cell"], other["cell"])
        for f in ("x", "y", "z", "LAGS_C", "LAGS_F1", "LAGS_F2", "T", "gap", "slip"):
            d = np.abs(one[f] - other[f]).max()
            assert d <= 1e-10 * (scale if f in ("LAGS_C", "T") else 1.0), (n, f, d)
