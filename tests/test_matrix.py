"""Jacobian storage (issue 6): SBAIJ (upper triangle) for symmetric factorisations, AIJ otherwise."""
import numpy as np
import pytest

from conftest import CASES, results, run_cli


@pytest.fixture
def options():
    """The PETSc options database, emptied of what a test sets."""
    from xfemcontact._petsc import PETSc

    opts = PETSc.Options()
    before = set(opts.getAll())
    yield opts
    for key in set(opts.getAll()) - before:
        opts.delValue(key)


def model_with_jacobian(case_name, options, **opts):
    from xfemcontact.case import load_case
    from xfemcontact.model import Model

    for k, v in opts.items():
        options.setValue(k, v)
    m = Model(load_case(CASES / case_name))
    m.jacobian(None, m.x, m.K, m.K)          # bulk + interface tangent at the initial point
    for k in opts:
        options.delValue(k)
    return m


def dense(A):
    import scipy.sparse as sp

    B = A.convert("aij") if "sbaij" in A.getType() else A
    ai, aj, av = B.getValuesCSR()
    return sp.csr_matrix((av, aj, ai), shape=B.getSize()).toarray()


@pytest.mark.parametrize("case_name", ["ssnv509a.toml", "validation/slip_straight_tria6.toml"])
def test_sbaij_holds_the_aij_matrix(options, case_name):
    """Default (cholesky): SBAIJ; -pc_type lu: AIJ; the same symmetric matrix, preallocation exact."""
    sym = model_with_jacobian(case_name, options)
    full = model_with_jacobian(case_name, options, pc_type="lu")
    assert sym.K.getType() == "seqsbaij" and full.K.getType() == "seqaij"
    S = dense(sym.K)
    A = dense(full.K)
    assert np.abs(A - A.T).max() <= 1e-12 * np.abs(A).max()
    assert np.abs(S - A).max() <= 1e-12 * np.abs(A).max()
    info = sym.K.getInfo()
    assert info["nz_unneeded"] == 0                          # serial counts are exact
    # PETSc reports SBAIJ counts as the full symmetric pattern's
    assert info["nz_used"] == info["nz_allocated"] == full.K.getInfo()["nz_used"]


def test_mat_type_option(tmp_path, run_once):
    """-mat_type aij with Cholesky gives the same interface values; an unknown type is refused."""
    b = tmp_path / "b"
    p, a = run_once(CASES / "ssnv509a.toml")          # the default run, shared (conftest.Runs)
    assert p.returncode == 0
    p = run_cli(["run", CASES / "ssnv509a.toml", "-o", b, "-mat_type", "aij"])
    assert p.returncode == 0, p.stdout + p.stderr
    ra, rb = results(a), results(b)
    assert ra["linear_solver"]["matrix"] == "seqsbaij" and rb["linear_solver"]["matrix"] == "seqaij"
    for k in ("LAGS_C", "LAGS_F1"):
        assert np.allclose(ra["interface"][k], rb["interface"][k], rtol=0, atol=1e-10)
    p = run_cli(["run", CASES / "ssnv509a.toml", "-o", tmp_path / "c", "-mat_type", "dense"])
    assert p.returncode == 2
    assert "-mat_type dense" in p.stderr and len(p.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "c").exists()


@pytest.mark.mpi
def test_mpi_sbaij_and_aij_agree(tmp_path):
    """Two processes, both storages: the interface values of one process, preallocation holds."""
    one = tmp_path / "one"
    assert run_cli(["run", CASES / "ssnv509b.toml", "-o", one]).returncode == 0
    for extra in ((), ("-mat_type", "aij")):
        out = tmp_path / ("two" + "".join(extra))
        p = run_cli(["run", CASES / "ssnv509b.toml", "-o", out, *extra], np=2)
        assert p.returncode == 0, p.stdout + p.stderr
        assert results(out)["linear_solver"]["matrix"] == ("mpiaij" if extra else "mpisbaij")
        for k in ("LAGS_C", "LAGS_F1"):
            assert np.allclose(results(one)["interface"][k], results(out)["interface"][k], rtol=0, atol=1e-10)
