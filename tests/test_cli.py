"""The command line: exit codes, test table, results.json, PETSc options, one-line
refusals of bad input, and the output folder (complete or absent)."""
import re

import pytest

from conftest import ROOT, results, run_cli, write_case

GOOD = (ROOT / "tests" / "data" / "cases" / "elastic_rectangle.toml").read_text()
TIMEOUT = 120


def good_case(directory, name="case.toml", text=GOOD):
    return write_case(directory, text, name)


def listing(directory):
    """Every path under ``directory`` (hidden ones included), relative, sorted."""
    return sorted(str(p.relative_to(directory)) for p in directory.rglob("*"))


def error_lines(stderr):
    return [line for line in stderr.splitlines() if line.strip()]


# --- a good run -----------------------------------------------------------------------------

def test_good_case_exit_0_table_and_results(tmp_path):
    case = good_case(tmp_path)
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    # the test table: a header and one OK line per test
    lines = proc.stdout.splitlines()
    header = [i for i, line in enumerate(lines) if re.search(r"\bcomputed\b.*\breference\b", line)]
    assert len(header) == 1
    rows = lines[header[0] + 1: header[0] + 4]
    assert [row.split()[0] for row in rows] == ["OK", "OK", "OK"]
    assert any("DX everywhere" in row for row in rows)
    assert "NOOK" not in proc.stdout
    assert str(out) in proc.stdout
    for text in ("SNES Function norm", "KSP Object", "XFC:assembly"):   # no PETSc output unasked
        assert text not in proc.stdout
    r = results(out)
    assert r["converged"] is True
    assert r["reason"] > 0
    assert r["processes"] == 1
    assert r["dofs"]["total"] == r["dofs"]["displacement"] == 2 * 65 - 10   # 65 nodes; 9 DY on LIG1, DX at P1
    assert r["dofs"]["heaviside"] == r["dofs"]["LAGS_C"] == r["dofs"]["LAGS_F1"] == 0
    for key in ("mesh", "levelset", "layout", "assembly", "solve", "post"):
        assert key in r["timings"], key
        assert r["timings"][key] >= 0.0
    assert [t["ok"] for t in r["tests"]] == [True, True, True]
    assert (out / "fields.xdmf").is_file() and (out / "fields.h5").is_file()
    # the result files, and nothing else next to the output folder (no temporary folder)
    files = listing(tmp_path)
    assert {"out/fields.h5", "out/fields.xdmf", "out/results.json", "out/report.md"} <= set(files)
    assert [f for f in files if not f.startswith("out/")] == ["case.toml", "out"]


@pytest.mark.parametrize("option, expected", [
    ("-snes_monitor", "SNES Function norm"),
    ("-ksp_view", "mumps"),
    ("-log_view", "XFC:assembly"),
])
def test_petsc_options_pass_through(tmp_path, option, expected):
    case = good_case(tmp_path)
    proc = run_cli(["run", case, "-o", tmp_path / "out", option], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr
    assert expected in proc.stdout
    if option == "-ksp_view":
        assert "KSP Object" in proc.stdout
    # the options reach PETSc and nowhere else: no "unused option" warning, no error
    assert "WARNING" not in proc.stdout + proc.stderr


@pytest.mark.parametrize("args", [["--help"], ["-h"], ["run", "--help"], ["run", "-h"]])
def test_help(tmp_path, args):
    proc = run_cli(args, timeout=TIMEOUT, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    text = proc.stdout + proc.stderr
    assert "usage: xfemcontact run CASE.toml" in text
    assert "--overwrite" in text and "exit codes" in text
    assert listing(tmp_path) == []


def test_run_help_goes_to_stdout():
    proc = run_cli(["run", "--help"], timeout=TIMEOUT)
    assert proc.returncode == 0
    assert "usage: xfemcontact run CASE.toml" in proc.stdout and proc.stderr == ""


def test_top_level_help_goes_to_stdout():
    proc = run_cli(["--help"], timeout=TIMEOUT)
    assert proc.returncode == 0
    assert "usage: xfemcontact run CASE.toml" in proc.stdout and proc.stderr == ""


def test_no_arguments_or_unknown_command(tmp_path):
    proc = run_cli(["frobnicate"], timeout=TIMEOUT, cwd=tmp_path)
    assert proc.returncode == 2
    assert "usage:" in proc.stderr
    proc = run_cli(["run"], timeout=TIMEOUT, cwd=tmp_path)
    assert proc.returncode == 2
    assert listing(tmp_path) == []


def test_nook_exit_1(tmp_path):
    text = GOOD.replace("reference = 5.0e-5", "reference = 6.0e-5")
    assert text != GOOD
    case = good_case(tmp_path, text=text)
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out], timeout=TIMEOUT)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert re.search(r"^NOOK\s+MAX DY", proc.stdout, re.M)
    r = results(out)                                  # results are still written
    assert r["converged"] is True
    assert [t["ok"] for t in r["tests"]] == [False, True, True]


# --- the output folder ----------------------------------------------------------------------

def test_existing_output_folder_then_overwrite(tmp_path):
    case = good_case(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("previous results")
    proc = run_cli(["run", case, "-o", out], timeout=TIMEOUT)
    assert proc.returncode == 2
    lines = error_lines(proc.stderr)
    assert len(lines) == 1, proc.stderr
    assert str(out) in lines[0]
    assert "--overwrite" in lines[0]
    assert listing(tmp_path) == ["case.toml", "out", "out/keep.txt"]     # untouched

    (out / "keep.txt").unlink()                  # an empty folder holds nothing to lose
    assert run_cli(["run", case, "-o", out, "--overwrite"], timeout=TIMEOUT).returncode == 0
    before = (out / "results.json").read_text()
    proc = run_cli(["run", case, "-o", out, "--overwrite"], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr
    assert results(out)["converged"] is True
    assert (out / "results.json").read_text() != before               # replaced (timings)
    files = listing(tmp_path)
    assert {"out/results.json", "out/fields.xdmf", "out/.xfemcontact"} <= set(files)
    assert [f for f in files if not f.startswith("out/")] == ["case.toml", "out"]


def test_default_output_folder(tmp_path):
    good_case(tmp_path, "plate.toml")
    proc = run_cli(["run", "plate.toml"], timeout=TIMEOUT, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert results(tmp_path / "results" / "plate")["case"] == "plate"


# --- bad input: exit 2, one line naming the file and the key, nothing created ----------------

BAD = {
    # name: (edit of the good case, what the one line must contain)
    "unknown-key": (("nu = 0.3", "nuu = 0.3"), ["material.nuu", "unknown key", "'nu'"]),
    "unknown-table": (("[material]", "[materail]"), ["materail", "unknown key", "'material'"]),
    "missing-group": (('group = "LIG1"', 'group = "LIG7"'),
                      ["dirichlet[0].group", "'LIG7'", "LIG1, LIG2, LIG3, LIG4", "P1", "SURF"]),
    "missing-traction-group": (('group = "LIG3"', 'group = "TOP"'),
                               ["traction[0].group", "'TOP'", "LIG3", "SURF"]),
    "missing-mesh-file": (("rectangle = { nx = 4, ny = 4 }", 'file = "nowhere/mesh.med"'),
                          ["mesh.file", "nowhere/mesh.med", "not found"]),
    "wrong-type": (("E = 2.0e11", 'E = "big"'), ["material.E", "number", "big"]),
    "wrong-type-int": (("nx = 4,", "nx = 4.5,"), ["mesh.rectangle.nx", "integer"]),
    "out-of-range": (("nu = 0.3", "nu = 0.7"), ["material.nu", "0.5"]),
    "bad-formula": (('DY = "5e-6*y"', 'DY = "5e-6*z"'), ["reference.DY", "z"]),
    "toml-syntax": (("nu = 0.3", "nu = = 0.3"), ["line"]),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_case_one_line_exit_2(tmp_path, name):
    (old, new), expected = BAD[name]
    assert old in GOOD
    text = GOOD.replace(old, new, 1)
    (tmp_path / "cases").mkdir()
    case = good_case(tmp_path / "cases", f"{name}.toml", text)
    before = listing(tmp_path)
    # the default output folder would be results/<name> in the working folder
    proc = run_cli(["run", "cases/" + case.name], timeout=TIMEOUT, cwd=tmp_path)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = error_lines(proc.stderr)
    assert len(lines) == 1, proc.stderr
    line = lines[0]
    assert "Traceback" not in proc.stderr
    assert f"cases/{name}.toml" in line                              # names the file
    for part in expected:
        assert part in line, (part, line)
    assert not re.search(r"results/|NOOK|^OK", proc.stdout, re.M)
    # no output folder, no temporary folder, nothing at all
    leftover = sorted(set(listing(tmp_path)) - set(before))
    assert leftover == []


def test_missing_group_in_mesh_file(tmp_path):
    """The group check names the mesh file and lists its groups."""
    from conftest import MESHES

    text = GOOD.replace("rectangle = { nx = 4, ny = 4 }", f'file = "{MESHES / "ssnv509b.mmed"}"')
    text = text.replace('group = "P1"', 'group = "PP1"')
    case = good_case(tmp_path, text=text)
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out], timeout=TIMEOUT)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = error_lines(proc.stderr)
    assert len(lines) == 1, proc.stderr
    for part in (str(case), "dirichlet[1].group", "'PP1'", "ssnv509b.mmed", "LIG1", "P1", "SURF"):
        assert part in lines[0], (part, lines[0])
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")]


def test_refused_input_keeps_previous_results(tmp_path):
    """--overwrite with a case refused on input leaves the existing folder untouched."""
    good = good_case(tmp_path)
    out = tmp_path / "out"
    assert run_cli(["run", good, "-o", out], timeout=TIMEOUT).returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    bad = good_case(tmp_path, "bad.toml", GOOD.replace('group = "LIG1"', 'group = "LIG9"'))
    proc = run_cli(["run", bad, "-o", out, "--overwrite"], timeout=TIMEOUT)
    assert proc.returncode == 2
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml", "case.toml", "out"]


def test_missing_case_file(tmp_path):
    proc = run_cli(["run", "nothere.toml"], timeout=TIMEOUT, cwd=tmp_path)
    assert proc.returncode == 2
    lines = error_lines(proc.stderr)
    assert len(lines) == 1 and "nothere.toml" in lines[0]
    assert listing(tmp_path) == []


@pytest.mark.mpi
def test_bad_case_one_line_under_mpirun(tmp_path):
    case = good_case(tmp_path, text=GOOD.replace("nu = 0.3", "nuu = 0.3"))
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out], np=2, timeout=TIMEOUT)
    assert proc.returncode == 2
    # mpirun adds its own banner; ours is printed once (rank 0), on one line
    ours = [line for line in proc.stderr.splitlines() if str(case) in line]
    assert len(ours) == 1, proc.stderr
    assert "material.nuu" in ours[0] and "'nu'" in ours[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml"]


@pytest.mark.parametrize("env, expected", [
    ({}, "ob1"),                                                              # no launcher
    ({"OMPI_MCA_pml": "ucx"}, "ucx"),                                         # the user's choice
    ({"OMPI_COMM_WORLD_SIZE": "2", "OMPI_COMM_WORLD_LOCAL_SIZE": "2", "PMIX_RANK": "0"}, "ob1"),
    ({"OMPI_COMM_WORLD_SIZE": "4", "OMPI_COMM_WORLD_LOCAL_SIZE": "2", "PMIX_RANK": "0"}, None),
    ({"SLURM_PROCID": "0"}, None),                                            # hosts unknown
])
def test_open_mpi_pml_only_chosen_on_one_host(env, expected):
    """ob1 is chosen before MPI starts only when every process is on this machine and
    the user did not choose a PML."""
    from xfemcontact._petsc import _single_host_pml
    _single_host_pml(env)
    assert env.get("OMPI_MCA_pml") == expected
