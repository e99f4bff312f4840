"""Reliability at the edges (issue 22): every failure is one line naming the file, key,
option or group at fault with its exit code (2 bad input, 3 no convergence, 129/130/143
interrupted), checked before the mesh is built where it can be; no hung MPI job; --overwrite
that cannot destroy what xfemcontact did not write; mesh files that cannot read other files.

The gaps of the issue, in its order: 1 signals under MPI, 2 the overwrite guard, 3 the output
location, 4 group dimensions, 5 tracebacks (options, integers, NaN, titles, SIGHUP, closed
pipe), 6 interface resolution, 7 confined mesh reading, 8 the folder swap, 9 misleading
messages; and issue 18 point 4.  Most probes run in this process (the checks are functions);
a few run the command line end to end.
"""
import base64
import json
import os
import re
import signal
import subprocess
import sys
import time
import zlib
from pathlib import Path

import numpy as np
import pytest

from conftest import ENV, ROOT, results, run_cli, write_case

TIMEOUT = 120
GOOD = (ROOT / "tests" / "data" / "cases" / "elastic_rectangle.toml").read_text()
CONTACT = """\
title = "probe"
[mesh]
rectangle = { nx = 8, ny = 8, x = [0.0, 10.0], y = [0.0, 10.0], cell = "QUAD8" }
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
DY = -1.0e-6
[parameters]
xc = 5.0
yc = 11.77
[interface]
level_set = "(x-xc)**2 + (y-yc)**2 - 64.27"
law = "contact"
[contact]
frottement = "COULOMB"
coulomb = 0.3
coef_cont = 1.0e6
coef_frot = 1000.0
seuil_init = -5.0
[newton]
resi_glob_rela = 1.0e-9
[output]
plots = false
"""
CIRCLE = 'level_set = "(x-xc)**2 + (y-yc)**2 - 64.27"'


def edited(text, *edits):
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def one_line(proc):
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    return lines[0]


def listing(directory):
    return sorted(str(p.relative_to(directory)) for p in Path(directory).rglob("*"))


def load(tmp_path, text, name="case.toml"):
    from xfemcontact.case import load_case

    return load_case(write_case(tmp_path, text, name))


def checked(tmp_path, text):
    """The preflight of a case (in this process): its Preflight, or the error it raises."""
    from xfemcontact import preflight

    case = load(tmp_path, text)
    return preflight.preflight(case, preflight.build_mesh(case))


def _start(args, np_=None):
    cmd = [sys.executable, "-m", "xfemcontact", *[str(a) for a in args]]
    if np_:
        cmd = ["mpirun", "-n", str(np_), "--oversubscribe"] + cmd
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=ENV, cwd=ROOT)


# --- 1. a signal to one MPI process ends the whole job ---------------------------------------

def _rank_pids(launcher, size, limit=60.0):
    """{rank: pid} of the processes ``launcher`` (mpirun) started."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < limit:
        pids = {}
        for child in Path("/proc").iterdir():
            if not child.name.isdigit():
                continue
            try:
                stat = (child / "stat").read_text()
                ppid = int(stat.rsplit(")", 1)[1].split()[1])
                env = (child / "environ").read_bytes().split(b"\0")
            except (OSError, IndexError, ValueError):
                continue
            if ppid != launcher.pid:
                continue
            for item in env:
                if item.startswith(b"OMPI_COMM_WORLD_RANK="):
                    pids[int(item.split(b"=")[1])] = int(child.name)
        if len(pids) == size:
            return pids
        time.sleep(0.05)
    raise AssertionError("ranks not found")


@pytest.mark.mpi
@pytest.mark.slow
def test_sigterm_to_one_rank_ends_the_job(tmp_path):
    """Gap 1: SIGTERM to rank 1 of 2 while they solve: the job ends within seconds (it hung),
    exit code 143, one line from the signalled process, no result folder."""
    case = write_case(tmp_path, edited(CONTACT, ("nx = 8, ny = 8", "nx = 110, ny = 110")))
    out = tmp_path / "out"
    proc = _start(["run", case, "-o", out], np_=2)
    line = proc.stdout.readline()                     # set up: solving now
    assert "dofs on 2 process(es)" in line, line + proc.communicate()[1]
    pids = _rank_pids(proc, 2)
    time.sleep(0.5)
    os.kill(pids[1], signal.SIGTERM)
    t0 = time.monotonic()
    try:
        _, stderr = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail("the job hangs after SIGTERM to one process")
    assert time.monotonic() - t0 < 15
    assert proc.returncode == 143, stderr
    assert "interrupted (SIGTERM) on process 1 of 2: stopping every process" in stderr
    assert not out.exists()


# --- 2. --overwrite replaces only what xfemcontact wrote -------------------------------------

def test_overwrite_refuses_a_folder_we_did_not_write(tmp_path):
    case = write_case(tmp_path, GOOD)
    d = tmp_path / "d"
    d.mkdir()
    (d / "keep.txt").write_text("x")
    proc = run_cli(["run", case, "-o", d, "--overwrite"], timeout=TIMEOUT)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    line = one_line(proc)
    assert line == (f"error: {d}: not a result folder of xfemcontact (it holds keep.txt): "
                    f"--overwrite replaces only result folders xfemcontact wrote (move what you "
                    f"keep there, or choose another -o)")
    assert "dofs on" not in proc.stdout
    assert (d / "keep.txt").read_text() == "x"


def test_overwrite_refuses_the_case_folder_and_extra_files(tmp_path):
    from xfemcontact.errors import CaseError
    from xfemcontact.output.folder import OutputFolder

    write_case(tmp_path, GOOD)
    with pytest.raises(CaseError, match=r"not a result folder of xfemcontact \(it holds "
                                        r"case.toml\)"):
        OutputFolder(tmp_path, overwrite=True)
    with pytest.raises(CaseError, match="give the result folder by its name"):
        cwd = os.getcwd()
        try:
            out = tmp_path / "out"
            out.mkdir()
            os.chdir(out)
            OutputFolder(".", overwrite=True)          # empty: ours, but not by that name
        finally:
            os.chdir(cwd)
    # a result folder of ours where the user put a file of their own
    out = tmp_path / "res"
    f = OutputFolder(out)
    f.write_text("results.json", "{}")
    f.commit()
    assert json.loads((out / ".xfemcontact").read_text())["files"] == ["results.json"]
    OutputFolder(out, overwrite=True)                  # ours: accepted
    (out / "notes.txt").write_text("mine")
    with pytest.raises(CaseError, match=r"holds files xfemcontact did not write \(notes.txt\)"):
        OutputFolder(out, overwrite=True)
    # a symbolic link is not replaced (the link would go, not what it points to)
    (tmp_path / "link").symlink_to(out)
    with pytest.raises(CaseError, match="is a symbolic link"):
        OutputFolder(tmp_path / "link", overwrite=True)


# --- 3. the output location is checked before the mesh is built ------------------------------

def test_output_location_checked_before_the_solve(tmp_path):
    case = write_case(tmp_path, GOOD)
    (tmp_path / "afile").write_text("x")
    proc = run_cli(["run", case, "-o", tmp_path / "afile" / "x"], timeout=TIMEOUT)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert one_line(proc) == (f"error: {tmp_path}/afile/x: cannot create the output folder: "
                              f"{tmp_path}/afile is not a folder")
    assert "dofs on" not in proc.stdout


@pytest.mark.parametrize("where, expected", [
    ("a" * 300, "output folder name too long (300 bytes; at most "),
    ("/sys/xfemcontact-probe", "cannot create the output folder: Operation not permitted"),
])
def test_output_location_refused(tmp_path, where, expected):
    from xfemcontact.errors import CaseError
    from xfemcontact.output.folder import OutputFolder

    if where.startswith("/sys") and not Path("/sys").is_dir():
        pytest.skip("no /sys")
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        with pytest.raises(CaseError) as info:
            OutputFolder(where)
    finally:
        os.chdir(cwd)
    assert expected in str(info.value)
    assert listing(tmp_path) == []


def _tmpfs(path, options):
    path.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
                          capture_output=True)
    if done.returncode:
        pytest.skip("cannot mount a tmpfs here")
    return path


@pytest.mark.parametrize("options, fill, expected", [
    ("ro,size=1m", False, "Read-only file system"),
    ("size=64k", True, "No space left on device"),
])
def test_read_only_or_full_file_system(tmp_path, options, fill, expected):
    from xfemcontact.errors import CaseError
    from xfemcontact.output.folder import OutputFolder

    mount = _tmpfs(tmp_path / "fs", options)
    try:
        if fill:
            subprocess.run(["dd", "if=/dev/zero", f"of={mount}/fill", "bs=1k", "count=100"],
                           capture_output=True)
        with pytest.raises(CaseError, match=f"{mount}/out: cannot create the output folder: "
                                            f"{expected}"):
            OutputFolder(mount / "out")
    finally:
        subprocess.run(["umount", str(mount)], capture_output=True)


# --- 4. groups of the right dimension ---------------------------------------------------------

@pytest.mark.parametrize("load, expected", [
    ('[[traction]]\ngroup = "P2"\nFX = 1.0\n',
     "traction[0].group: 'P2' is a node group of rectangle; tractions (FORCE_CONTOUR, PRES_REP) "
     "act on edge groups (edge groups: LIG1, LIG2, LIG3, LIG4, bottom, left, right, top)"),
    ('[[traction]]\ngroup = "SURF"\nFX = 1.0\n', "traction[0].group: 'SURF' is a cell group"),
    ('[[dirichlet]]\ngroup = "SURF"\nDX = 0.0\n',
     "dirichlet[2].group: 'SURF' is a cell group of rectangle; imposed displacements act on edge "
     "or node groups"),
])
def test_group_of_the_wrong_dimension(tmp_path, load, expected):
    from xfemcontact.errors import CaseError

    with pytest.raises(CaseError) as info:
        checked(tmp_path, edited(CONTACT, ("[parameters]", load + "[parameters]")))
    assert str(info.value).startswith(f"{tmp_path}/case.toml: {expected}"), str(info.value)


# --- 5. options, integers, NaN results, titles, signals, closed pipes ------------------------

@pytest.fixture
def petsc_options():
    """Set PETSc options for one check (as the command line would); removed afterwards."""
    from xfemcontact._petsc import PETSc

    opts = PETSc.Options()
    given = []

    def is_value(tok):
        return not tok.startswith("-") or tok[1:2].isdigit()

    def setter(*argv):
        i = 0
        while i < len(argv):
            name, value = argv[i].lstrip("-"), None
            if i + 1 < len(argv) and is_value(argv[i + 1]):
                value, i = argv[i + 1], i + 1
            opts.setValue(name, value)
            given.append(name)
            i += 1
        return list(argv)
    yield setter
    for name in given:
        opts.delValue(name)


OPTION_PROBES = {
    # argv: the one line (exit code 2)
    ("-pc_type", "nonsense"): "-pc_type nonsense: Unable to find requested PC type nonsense "
                              "(accepted here: ",
    ("-ksp_type", "foo"): "-ksp_type foo: Unable to find requested KSP type foo (accepted here: ",
    ("-snes_max_it", "-1"): "-snes_max_it -1: expected an integer from 1 to 1000000 (it "
                            "overrides newton.iter_glob_maxi)",
    ("-snes_rtol", "abc"): "-snes_rtol abc: expected a number > 0 (it overrides "
                           "newton.resi_glob_rela)",
    ("-pc_factor_mat_solver_type", "superlu"):
        "-pc_factor_mat_solver_type superlu: MatSolverType superlu does not support matrix type "
        "seqsbaij (available here: with -pc_type cholesky: ",
    ("-mat_mumps_icntl_7", "99"): "-mat_mumps_icntl_7 99: Valid values are 0=AMD, 2=AMF",
    ("-contact_snes_max_it", "0"): "-contact_snes_max_it 0: expected an integer from 1 to "
                                   "1000000 (it overrides contact.iter_cont_maxi)",
    ("-friction_snes_max_it", "-3"): "-friction_snes_max_it -3: expected an integer from 1 to "
                                     "1000000 (it overrides contact.iter_frot_maxi)",
    ("-snes_max_it", "999999999999"): "-snes_max_it 999999999999: expected an integer from 1 "
                                      "to 1000000",
    ("-mat_mumps_icntl_24", "99999999999"): "-mat_mumps_icntl_24 99999999999: integer out of "
                                            "range (PETSc integers here are from",
    ("-snes_type", "aspin"): "-snes_type aspin: not a nonlinear solver xfemcontact can drive",
    ("-contact_snes_type", "newtonls"): "-contact_snes_type newtonls: the contact status loop is "
                                        "a loop of xfemcontact",
    ("-snes_monitr",): "-snes_monitr: unknown option: no solver reads it (did you mean "
                       "-snes_monitor?)",
}


@pytest.mark.parametrize("argv", sorted(OPTION_PROBES), ids=" ".join)
def test_petsc_option_refused(petsc_options, argv):
    from xfemcontact.solver.newton import OptionError, check_options

    with pytest.raises(OptionError) as info:
        check_options(petsc_options(*argv))
    assert str(info.value).startswith(OPTION_PROBES[argv]), str(info.value)
    assert "\n" not in str(info.value)


def test_petsc_options_in_use_are_accepted(petsc_options):
    from xfemcontact.solver.newton import check_options

    check_options(petsc_options("-snes_monitor", "-contact_snes_monitor", "-friction_snes_monitor",
                                "-ksp_view", "-snes_converged_reason", "-mat_mumps_icntl_24", "1",
                                "-snes_rtol", "1e-8", "-friction_snes_max_it", "20",
                                "-pc_type", "lu", "-snes_view", "-mat_mumps_icntl_14", "50"))


def test_every_documented_mumps_ordering_runs(tmp_path):
    # -mat_mumps_icntl_7 4 (PORD) killed every run with exit status 255: the options were
    # tried on a 2 x 2 system, a graph PORD cannot order ("no valid number of stages in
    # multisector"); the README lists 0, 2, 4, 6 and 7
    case = write_case(tmp_path, GOOD)
    for ordering in (0, 2, 4, 6, 7):
        out = tmp_path / f"out{ordering}"
        r = run_cli(["run", case, "-o", out, "-mat_mumps_icntl_7", ordering])
        assert r.returncode == 0, (ordering, r.stderr)
        used = results(out)["linear_solver"]["mumps"]["ordering"]
        assert used == ordering or ordering == 7, (ordering, used)


@pytest.mark.parametrize("argv, expected", [
    (("-xfc_friction_unknown", "nonsense"),
     "-xfc_friction_unknown nonsense: unknown value (expected one of LAGS_F1, TRACTION)"),
    (("-xfc_friction_unknown",), "-xfc_friction_unknown: needs a value (one of LAGS_F1, TRACTION)"),
    (("-xfc_frictionunknown", "traction"),
     "-xfc_frictionunknown: unknown option (did you mean -xfc_friction_unknown? known: "
     "-xfc_friction_unknown, -xfc_friction_newton, -xfc_friction_line_search, -xfc_coarse_start, "
     "-xfc_mesh_max_mb, -xfc_memory_limit)"),
    (("-xfc_mesh_max_mb", "-5"), "-xfc_mesh_max_mb -5: out of range (expected a number > 0 and "
                                 "<= 1e+09)"),
])
def test_xfc_option_refused(petsc_options, argv, expected):
    from xfemcontact import options

    petsc_options(*argv)
    with pytest.raises(options.OptionError) as info:
        options.check_all()
    assert str(info.value) == expected


def test_xfc_options_read_and_listed(petsc_options):
    from xfemcontact import options

    petsc_options("-xfc_friction_unknown", "traction")
    assert options.get("friction_unknown", "LAGS_F1") == "TRACTION"
    help_text = "\n".join(options.help_lines())
    for o in options.OPTIONS.values():
        assert o.flag in help_text and o.accepted() in help_text


def test_bad_options_end_to_end(tmp_path):
    """Exit 2 and one line, before the mesh, for an unknown PC and a wrong -xfc_ value (both
    were a traceback or silently ignored); -help lists the -xfc_* options."""
    case = write_case(tmp_path, CONTACT)
    for argv, expected in ((["-pc_type", "nonsense"], "error: -pc_type nonsense: Unable to find "
                                                      "requested PC type nonsense"),
                           (["-xfc_friction_unknown", "nonsense"],
                            "error: -xfc_friction_unknown nonsense: unknown value")):
        proc = run_cli(["run", case, "-o", tmp_path / "out", *argv], timeout=TIMEOUT)
        assert proc.returncode == 2, proc.stdout + proc.stderr
        assert one_line(proc).startswith(expected)
        assert "dofs on" not in proc.stdout and not (tmp_path / "out").exists()
    proc = run_cli(["run", "--help"], timeout=TIMEOUT)
    assert "-xfc_friction_unknown <the case's contact.friction_unknown>" in proc.stdout


@pytest.mark.parametrize("edit, expected", [
    (("resi_glob_rela = 1.0e-9", "resi_glob_rela = 1.0e-9\niter_glob_maxi = 99999999999999999"),
     "newton.iter_glob_maxi: must be >= 1 and <= 1000000, got 99999999999999999"),
    (("seuil_init = -5.0", "seuil_init = -5.0\niter_cont_maxi = 9223372036854775807"),
     "contact.iter_cont_maxi: must be >= 1 and <= 1000000, got 9223372036854775807"),
    (('title = "probe"', 'title = "' + "T" * 3000 + '"'),
     "title: too long (3000 characters, at most 200)"),
    (('title = "probe"', 'title = "a\\u001b[31mred\\u0007"'),
     "title: control character U+001B at position 2 (one line of printable text)"),
    (("plots = false", 'plots = false\n[[test]]\nname = "a"\nfield = "DX"\ntype = "MAX"\n'
                       'reference = 0.0\ntolerance = 1.0\ncriterion = "ABSOLU"\n[[test]]\n'
                       'name = "a"\nfield = "DY"\ntype = "MAX"\nreference = 0.0\n'
                       'tolerance = 1.0\ncriterion = "ABSOLU"'),
     'test[1].name: duplicate test name "a" (also test[0]): give each [[test]] its own name'),
])
def test_case_values_refused(tmp_path, edit, expected):
    from xfemcontact.errors import CaseError

    with pytest.raises(CaseError) as info:
        load(tmp_path, edited(CONTACT, edit))
    assert str(info.value) == f"{tmp_path}/case.toml: {expected}"


GAUSS = ("frottement =", 'integration = "GAUSS"\nfrottement =')


@pytest.mark.parametrize("edits", [[("E = 1.0e6", "E = 1.0e300")], [("DY = -1.0e-6", 'DY = "1e200"')],
                                   [("coef_cont = 1.0e6", "coef_cont = 1.0e300"), GAUSS],
                                   [("coef_frot = 1000.0", "coef_frot = 1.0e300"), GAUSS]],
                         ids=["E-1e300", "DY-1e200", "coef_cont-1e300-gauss", "coef_frot-1e300-gauss"])
def test_nan_residual_writes_results_and_plots_exit_3(tmp_path, edits):
    """With plots on, a NaN residual crashed the convergence plot and lost the folder (and
    the COEF_FROT hint of the diagnosis crashed on the conditions at the dofs)."""
    case = write_case(tmp_path, edited(CONTACT, *edits, ("plots = false", "plots = true")))
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out], timeout=TIMEOUT)
    assert proc.returncode == 3, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "no convergence: Newton" in errors[0]
    if "coef" not in edits[0][1]:
        assert "the residual is NaN or infinite" in errors[0]
    assert results(out)["converged"] is False
    assert (out / "plot_deformed.png").is_file()


@pytest.mark.parametrize("key, value", [("coef_cont", "1.0e6"), ("coef_frot", "1000.0")])
def test_absurd_coefficient_changes_nothing_at_the_dofs(tmp_path, run_once, key, value):
    """At the dofs (NOEUD) with Coulomb's law in Newton the coefficients do not enter (the
    rows are scaled by E/h): 1e300 (which once overflowed to a NaN residual) gives the
    nominal answer bit for bit, without a word.  With the threshold fixed point
    (-xfc_friction_newton TRESCA) they scale rows: 1e300 is scaled back to 1e8 E/h with a
    warning, and the answer is the nominal one."""
    case = run_once.case(CONTACT)              # the nominal runs: one per session (conftest.Runs)
    absurd = write_case(tmp_path, edited(CONTACT, (f"{key} = {value}", f"{key} = 1.0e300")), "absurd.toml")
    (p, nominal), out = run_once(case), tmp_path / "out"
    assert p.returncode == 0
    proc = run_cli(["run", absurd, "-o", out], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr
    assert "contact." not in proc.stderr
    assert (out / "interface.csv").read_bytes() == (nominal / "interface.csv").read_bytes()
    tresca = ["-xfc_friction_newton", "TRESCA"]
    (p, nominal), out = run_once(case, *tresca), tmp_path / "out_t"
    assert p.returncode == 0
    proc = run_cli(["run", absurd, "-o", out, *tresca], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr
    assert f"contact.{key} = 1e+300" in proc.stderr and "1e+08 times E/h instead" in proc.stderr
    assert any(f"contact.{key}" in w for w in results(out)["warnings"])
    a, b = results(out)["interface"], results(nominal)["interface"]
    for field in ("LAGS_C", "LAGS_F1", "gap", "slip"):
        scale = max(np.abs(b[field]).max(), 1e-30)
        assert np.abs(np.array(a[field]) - np.array(b[field])).max() < 1e-9 * scale, field


def test_mathtext_in_title(tmp_path):
    """A title with '$...$' crashed matplotlib's mathtext parser after the solve (no folder)."""
    case = write_case(tmp_path, edited(CONTACT, ('title = "probe"', 'title = "cost $\\\\frac{$ a"'),
                                       ("plots = false", "plots = true")))
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stderr == ""
    assert (out / "plot_deformed.png").is_file()


def _interrupt_while_solving(tmp_path, sig):
    case = write_case(tmp_path, edited(GOOD, ("nx = 4, ny = 4", "nx = 200, ny = 200")))
    out = tmp_path / "out"
    proc = _start(["run", case, "-o", out])
    assert "dofs on 1 process(es)" in proc.stdout.readline()
    proc.send_signal(sig)
    _, stderr = proc.communicate(timeout=TIMEOUT)
    return proc.returncode, stderr, out


def test_sighup_is_a_clean_interruption(tmp_path):
    """SIGHUP ended in PETSc's MPI_ABORT banner, exit 59."""
    code, stderr, out = _interrupt_while_solving(tmp_path, signal.SIGHUP)
    assert code == 129, stderr
    assert stderr.strip() == "interrupted (SIGHUP): no results written"
    assert listing(tmp_path) == ["case.toml"]


def test_closed_standard_output(tmp_path):
    """``run ... | head -1``: the run goes on and writes its results (it aborted, exit 59)."""
    case = write_case(tmp_path, CONTACT)
    out = tmp_path / "out"
    proc = _start(["run", case, "-o", out, "-snes_monitor"])
    first = proc.stdout.readline()
    proc.stdout.close()                                 # the reader leaves
    stderr = proc.stderr.read()
    proc.wait(timeout=TIMEOUT)
    assert "dofs on" in first
    assert proc.returncode == 0, stderr
    assert stderr == ""
    assert results(out)["converged"] is True
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")]


# --- 6. interface resolution ------------------------------------------------------------------

SIN = (("nx = 8, ny = 8", "nx = 10, ny = 10"), (CIRCLE, 'level_set = "sin(20*x) + 0*y"'))


def test_under_resolved_level_set_refused(tmp_path):
    """sin(20 x) on 10 x 10 cells: was solved without a word (77 lifted edges)."""
    from xfemcontact.errors import GeometryError

    with pytest.raises(GeometryError) as info:
        checked(tmp_path, edited(CONTACT, *SIN))
    message = str(info.value)
    assert message.startswith(f"{tmp_path}/case.toml: interface.level_set: the interface the mesh "
                              f"represents is up to ")
    assert "the level set varies faster than the cells can follow: refine the mesh there, or " \
           "accept it with interface.max_offset = " in message


def test_under_resolved_level_set_accepted_with_warnings(tmp_path):
    """Accepted with max_offset, the run says how far off the interface is.  Law bonded:
    contact with friction on sin(20 x) across 10 cells (one crossing pushed 1.2 h off) does
    not converge (exit 3) -- before the friction statuses judged on the trial traction it
    ended with exit 0 only by forcing convergence twice (CONTACT3_86) after 1 Newton
    iteration."""
    case = write_case(tmp_path, edited(CONTACT, *SIN, ('law = "contact"',
                                                        'law = "bonded"\nmax_offset = 5.0')))
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    warnings = [line for line in proc.stderr.splitlines() if line.startswith("warning: ")]
    assert any("the interface the mesh represents is up to" in w for w in warnings), warnings
    assert any("cell edge(s) twice" in w and "the mesh is too coarse" in w for w in warnings)
    r = results(out)
    assert r["interface_resolution"]["offset_h"] > 0.5
    assert r["geometry"]["readjusted"]["lifted_edges"] > 4


def test_resolved_interfaces_are_silent(tmp_path):
    """The SSNV509 circle and a straight line: nothing to say, offset at round-off."""
    for level_set in (CIRCLE, 'level_set = "y - 0.5*x - 2.5"'):
        pre = checked(tmp_path, edited(CONTACT, (CIRCLE, level_set)))
        assert pre.warnings == []
        assert pre.resolution["offset_h"] < 1e-9


# the same check in 3-D: one code (preflight.interface_resolution), a 7 x 7 x 7 grid of HEXA20
# cells, 84 points on TETRA10
BOX3D = """\
title = "probe 3-D"
[mesh]
box = {nx = 2, ny = 2, nz = 2, x = [0, 1], y = [0, 1], z = [0, 1], cell = "HEXA20"}
[material]
E = 1.0e6
nu = 0.3
model = "3D"
[[dirichlet]]
group = "bottom"
DX = 0.0
DY = 0.0
DZ = 0.0
[[dirichlet]]
group = "top"
DZ = -1.0e-6
[interface]
level_set = "sqrt((x - 0.5)**2 + (y - 0.5)**2 + (z - 0.5)**2) - 0.3"
law = "bonded"
[output]
plots = false
formats = []
"""
#: the box of BOX3D on TETRA10 (6 a hexahedron), a smaller sphere off the vertices
TETRA3D = (('cell = "HEXA20"', 'cell = "TETRA10"'),
           ("(x - 0.5)**2 + (y - 0.5)**2 + (z - 0.5)**2) - 0.3", "(x - 0.3)**2 + (y - 0.42)**2 + (z - 0.7)**2) - 0.12"))
SPHERE_WARNING = ("interface.level_set: the interface the mesh represents is up to {:.2g} h ({:.3g} m) from "
                  "the zero of the level set, near ({:.4g}, {:.4g}, {:.4g}); refine the mesh there for a "
                  "closer interface")


@pytest.mark.parametrize("edits", [(), TETRA3D], ids=["HEXA20", "TETRA10"])
def test_sphere_on_a_coarse_box_warned_3d(tmp_path, edits):
    """A sphere (its distance function, which P2 does not hold) on a coarse 3-D box: the
    interface the mesh represents is 0.076 h (HEXA20) and 0.14 h (TETRA10, R = 0.12 m) off
    on 2 x 2 x 2 cells, a warning, as in 2-D; with max_offset below that the case is
    refused, one line."""
    from xfemcontact.errors import GeometryError

    text = edited(BOX3D, *edits)
    pre = checked(tmp_path, text)
    r = pre.resolution
    assert r["seen"] and not r["refused"] and len(r["at"]) == 3 and r["cell"] is not None
    assert 0.07 < r["offset_h"] < 0.15 and r["sampled_cells"] > 0
    assert pre.warnings == [f"{tmp_path}/case.toml: " + SPHERE_WARNING.format(r["offset_h"], r["offset_m"], *r["at"])]
    with pytest.raises(GeometryError) as info:
        checked(tmp_path, edited(text, ('law = "bonded"', 'law = "bonded"\nmax_offset = 0.05')))
    assert str(info.value).endswith("the level set varies faster than the cells can follow: refine the mesh "
                                    f"there, or accept it with interface.max_offset = {r['offset_h'] * 1.01:.2g} "
                                    "(now 0.05)")


def test_sphere_on_a_coarse_box_run_3d(tmp_path):
    """From the command line: the warning on stderr, the case solved (exit 0), results.json
    ``interface_resolution`` with its 3-D point."""
    case = write_case(tmp_path, BOX3D)
    proc = run_cli(["run", case, "-o", tmp_path / "out", "-q"], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert [line[:60] for line in proc.stderr.splitlines()] == \
        [f"warning: {case}: interface.level_set: the interface the mesh represents"[:60]]
    r = results(tmp_path / "out")["interface_resolution"]
    assert 0.06 < r["offset_h"] < 0.1 and len(r["at"]) == 3


@pytest.mark.mpi
def test_under_resolved_level_set_refused_3d(tmp_path):
    """sin(20 x) across 10 HEXA20 cells (the 2-D probe in 3-D): refused, exit 2, one line
    (1.2 h off, as in 2-D), on one process and on two (the check runs on rank 0, every
    process raises it; mpirun adds its banner), no output folder."""
    text = edited(BOX3D, ("nx = 2, ny = 2, nz = 2, x = [0, 1]", "nx = 10, ny = 2, nz = 2, x = [0, 10]"),
                  ("sqrt((x - 0.5)**2 + (y - 0.5)**2 + (z - 0.5)**2) - 0.3", "sin(20*x) + 0*y"))
    case = write_case(tmp_path, text)
    for np_ in (None, 2):
        proc = run_cli(["run", case, "-o", tmp_path / "out"], np=np_, timeout=TIMEOUT)
        assert proc.returncode == 2, proc.stdout + proc.stderr
        errors = [line for line in proc.stderr.splitlines() if line.startswith("error: ")]  # and mpirun's banner
        assert len(errors) == 1 and "Traceback" not in proc.stderr, proc.stderr
        assert errors[0].startswith(f"error: {case}: interface.level_set: the interface the mesh represents is "
                                         "up to 1.2 h (1.52 m) from the zero of the level set, near (1.333, 0, 0.08333); ")
        assert "or accept it with interface.max_offset = 1.3 (now 0.5)" in proc.stderr
        assert not (tmp_path / "out").exists()


def test_resolved_interfaces_are_silent_3d(tmp_path):
    """Planes (through vertices, along cell faces, inclined) and the quadratic sphere, which
    the quadratic cells hold exactly, on HEXA20 and TETRA10: offset 0 (round-off), no
    warning; so on every 3-D case of cases/validation."""
    from xfemcontact import preflight
    from xfemcontact.case import load_case

    for edits in ((), TETRA3D):
        for level_set in ("x + 0.5*y - 0.3*z - 0.41", "z - 0.5", "x + y - 1",
                          "(x - 0.47)**2 + (y - 0.52)**2 + (z - 0.49)**2 - 0.09"):
            text = re.sub(r"^level_set = .*$", f'level_set = "{level_set}"', edited(BOX3D, *edits), flags=re.M)
            pre = checked(tmp_path, text)
            assert pre.warnings == [] and pre.resolution["offset_h"] < 1e-9, (edits, level_set, pre.resolution)
    seen = 0
    for path in sorted((ROOT / "cases" / "validation").glob("*.toml")):
        case = load_case(path)
        if case.mesh.box is None or case.interface is None:
            continue
        pre = preflight.preflight(case, preflight.build_mesh(case))
        assert pre.warnings == [] and pre.resolution["offset_h"] < 1e-9, (path.name, pre.resolution)
        seen += 1
    assert seen >= 20


# --- 7. mesh files confined to the case, sizes bounded ---------------------------------------

def _xdmf(folder):
    """A valid TRIA6 XDMF + HDF5 pair in ``folder``; returns the XDMF text."""
    import meshio

    from xfemcontact.mesh.generate import rectangle

    r = rectangle(2, 2, cell="TRIA6")
    meshio.write(folder / "good.xdmf", meshio.Mesh(np.c_[r.points, np.zeros(len(r.points))],
                                                  [("triangle6", r.cells)]))
    return (folder / "good.xdmf").read_text()


@pytest.fixture
def hostile(tmp_path):
    """A case folder, an outside folder with data, and the XDMF text of a valid mesh."""
    import h5py

    case_dir, outside = tmp_path / "case", tmp_path / "outside"
    case_dir.mkdir()
    outside.mkdir()
    with h5py.File(outside / "secret.h5", "w") as f:
        f["data0"] = np.random.default_rng(0).random((25, 3))
    (outside / "secret.bin").write_bytes(np.random.default_rng(1).random(75).tobytes())
    return case_dir, outside, _xdmf(case_dir)


def _read(path, **kwargs):
    from xfemcontact.errors import MeshError
    from xfemcontact.mesh.read import read_mesh

    with pytest.raises(MeshError) as info:
        read_mesh(path, roots=[path.parent], **kwargs)
    message = str(info.value)
    assert "\n" not in message and "reshape" not in message
    return message


def test_xdmf_data_outside_the_case_refused(hostile):
    case_dir, outside, text = hostile
    probes = {
        "abs_binary.xdmf": text.replace('Format="HDF" Precision="8">good.h5:/data0',
                                        f'Format="Binary" Precision="8">{outside}/secret.bin'),
        "abs_hdf.xdmf": text.replace("good.h5:/data0", f"{outside}/secret.h5:/data0"),
        "relative.xdmf": text.replace("good.h5:/data0", "../outside/secret.h5:/data0"),
    }
    (case_dir / "escape").symlink_to(outside)
    probes["symlink.xdmf"] = text.replace("good.h5:/data0", "escape/secret.h5:/data0")
    for name, body in probes.items():
        (case_dir / name).write_text(body)
        message = _read(case_dir / name)
        assert "lies outside the folders of the case and mesh files: refused" in message, name
        assert "z from" not in message, message               # nothing decoded from it


def test_hdf5_links_and_storage_outside_refused(hostile):
    import h5py

    case_dir, outside, text = hostile
    import shutil

    shutil.copy(case_dir / "good.h5", case_dir / "link.h5")
    with h5py.File(case_dir / "link.h5", "a") as f:
        del f["data0"]
        f["data0"] = h5py.ExternalLink(str(outside / "secret.h5"), "/data0")
    (case_dir / "link.xdmf").write_text(text.replace("good.h5:", "link.h5:"))
    assert "HDF5 external link in link.h5 to" in _read(case_dir / "link.xdmf")
    shutil.copy(case_dir / "good.h5", case_dir / "ext.h5")
    with h5py.File(case_dir / "ext.h5", "a") as f:
        del f["data0"]
        f.create_dataset("data0", shape=(25, 3), dtype="f8",
                         external=[(str(outside / "secret.bin"), 0, 600)])
    (case_dir / "ext.xdmf").write_text(text.replace("good.h5:", "ext.h5:"))
    assert "HDF5 external storage in ext.h5:" in _read(case_dir / "ext.xdmf")


def test_declared_sizes_bounded(hostile):
    """A few KB declaring 240 GB (HDF5), a VTU that decompresses to 64 MB with a 1 MB limit:
    refused before anything is allocated."""
    import h5py
    import shutil

    case_dir, outside, text = hostile
    shutil.copy(case_dir / "good.h5", case_dir / "bomb.h5")
    with h5py.File(case_dir / "bomb.h5", "a") as f:
        del f["data0"]
        f.create_dataset("data0", shape=(10 ** 10, 3), dtype="f8", chunks=(65536, 3),
                         compression="gzip")
    (case_dir / "bomb.xdmf").write_text(text.replace("good.h5:", "bomb.h5:"))
    assert "the data bomb.h5 declares is 2.4e+05 MB, more than the" in _read(case_dir / "bomb.xdmf")
    block = 1 << 22
    comp = zlib.compress(b"\0" * block, 9)
    header = np.array([16, block, block] + [len(comp)] * 16, dtype=np.uint64).tobytes()
    data = base64.b64encode(header).decode() + base64.b64encode(comp * 16).decode()
    (case_dir / "bomb.vtu").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="0.1" '
        'byte_order="LittleEndian" header_type="UInt64" compressor="vtkZLibDataCompressor">'
        '<UnstructuredGrid><Piece NumberOfPoints="3" NumberOfCells="0"><Points>'
        f'<DataArray type="Float64" Name="Points" NumberOfComponents="3" format="binary">{data}'
        '</DataArray></Points></Piece></UnstructuredGrid></VTKFile>\n')
    message = _read(case_dir / "bomb.vtu", limit=10 ** 6)
    assert "the data it declares (decompressed) is 67.1 MB, more than the 1 MB allowed" in message
    assert "-xfc_mesh_max_mb" in message


def test_xml_entities_refused(hostile):
    case_dir, _, text = hostile
    (case_dir / "dtd.xdmf").write_text('<?xml version="1.0"?>\n<!DOCTYPE x [<!ENTITY e SYSTEM '
                                       '"file:///etc/hostname">]>\n' + text)
    assert "entity declarations are not accepted" in _read(case_dir / "dtd.xdmf")


@pytest.mark.parametrize("kind, expected", [("fifo", "a named pipe (FIFO), not a mesh file"),
                                            ("zero", "a character device, not a mesh file")])
def test_mesh_file_not_regular(tmp_path, kind, expected):
    """A FIFO or /dev/zero as mesh file was "mesh file not found"."""
    from xfemcontact.errors import CaseError

    path = tmp_path / "m.msh"
    if kind == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to("/dev/zero")
    with pytest.raises(CaseError) as info:
        load(tmp_path, edited(GOOD, ("rectangle = { nx = 4, ny = 4 }", 'file = "m.msh"')))
    assert str(info.value) == (f"{tmp_path}/case.toml: mesh.file: "
                               f"{path if kind == 'fifo' else '/dev/zero'}: {expected} (give a "
                               f"regular file)")


def test_truncated_gmsh_file(tmp_path):
    """Issue 18 point 4: said truncated or corrupt, not NumPy's "cannot reshape ..."."""
    text = (ROOT / "cases" / "meshes" / "ssnv509_jittered.msh").read_bytes()
    for size in (3000, 60000, 120000):
        (tmp_path / "t.msh").write_bytes(text[:size])
        assert _read(tmp_path / "t.msh") == (f"{tmp_path}/t.msh: cannot read as Gmsh: the file is "
                                             "truncated or "
                                             "corrupt (its data end before, or do not match, the "
                                             "sizes it declares)")


def test_hostile_mesh_end_to_end(hostile):
    case_dir, outside, text = hostile
    (case_dir / "m.xdmf").write_text(text.replace("good.h5:/data0", f"{outside}/secret.h5:/data0"))
    case = write_case(case_dir, edited(GOOD, ("rectangle = { nx = 4, ny = 4 }", 'file = "m.xdmf"')))
    proc = run_cli(["run", case, "-o", case_dir / "out"], timeout=TIMEOUT)
    assert proc.returncode == 2
    line = one_line(proc)
    assert line.startswith(f"error: {case}: mesh.file: m.xdmf: HDF5 DataItem '"), line
    assert line.endswith("/secret.h5' lies outside the folders of the case and mesh files: "
                         "refused (put the data next to the mesh file)"), line


# --- 8. the swap: atomic, crash-safe, stale folders cleaned ------------------------------------

def _ours(path, content):
    from xfemcontact.output.folder import OutputFolder

    f = OutputFolder(path, overwrite=True)
    f.write_text("results.json", content)
    f.commit()


def test_replacement_is_one_exchange(tmp_path, monkeypatch):
    from xfemcontact.output import folder as folder_mod

    out = tmp_path / "out"
    _ours(out, "old")
    calls = []
    real = folder_mod.exchange
    monkeypatch.setattr(folder_mod, "exchange", lambda a, b: (calls.append((a, b)), real(a, b)))
    _ours(out, "new")
    assert len(calls) == 1
    assert (out / "results.json").read_text() == "new"
    assert listing(tmp_path) == ["out", "out/.xfemcontact", "out/results.json"]


def test_crash_between_the_renames_is_repaired(tmp_path, monkeypatch):
    """Without an atomic exchange, a crash after the old folder was set aside leaves it
    complete as .out.old-PID; the next run puts it back before anything else."""
    import errno

    from xfemcontact.output import folder as folder_mod

    out = tmp_path / "out"
    _ours(out, "old")

    def unsupported(a, b):
        raise OSError(errno.EINVAL, "not supported")

    class Crash(Exception):
        pass

    real_rename = os.rename

    def rename(src, dst):
        if ".tmp-" in str(src):
            raise Crash()                    # the machine stops before the second rename
        real_rename(src, dst)
    monkeypatch.setattr(folder_mod, "exchange", unsupported)
    monkeypatch.setattr(os, "rename", rename)
    f = folder_mod.OutputFolder(out, overwrite=True)
    f.write_text("results.json", "new")
    with pytest.raises(Crash):
        f.commit()
    folder_mod._unlock(f._lock)                # the process is gone: its lock with it
    monkeypatch.setattr(os, "rename", real_rename)
    assert not out.exists()
    assert any(p.name.startswith(".out.old-") for p in tmp_path.iterdir())
    g = folder_mod.OutputFolder(out, overwrite=True)  # the next run
    assert (out / "results.json").read_text() == "old"
    assert any(c.endswith("-> out") for c in g.cleaned)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]   # the killed run's tmp too


def test_stale_temporary_folders_removed(tmp_path):
    """A SIGKILL while writing left .out.tmp-PID folders that later runs never removed; one
    that a running process holds (its lock) stays."""
    from xfemcontact.output import folder as folder_mod

    stale = tmp_path / ".out.tmp-999999"
    stale.mkdir()
    (stale / ".xfemcontact").write_text('{"written_by": "xfemcontact", "files": []}')
    (stale / "fields.h5").write_bytes(b"partial")
    busy = tmp_path / ".out.tmp-999998"
    busy.mkdir()
    (busy / ".xfemcontact").write_text('{"written_by": "xfemcontact", "files": []}')
    foreign = tmp_path / ".out.tmp-999997"
    foreign.mkdir()
    (foreign / "mine.txt").write_text("not ours")
    lock = folder_mod._lock(busy)
    try:
        f = folder_mod.OutputFolder(tmp_path / "out")
    finally:
        folder_mod._unlock(lock)
    assert f.cleaned == [".out.tmp-999999"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [".out.tmp-999997", ".out.tmp-999998"]


def test_two_runs_overwriting_the_same_folder(tmp_path, monkeypatch):
    """Run B puts its folder in place while run A replaces the same one: with two renames A
    then failed (ENOTEMPTY, a traceback); now the last one wins and nothing is left over."""
    from xfemcontact.output import folder as folder_mod

    out = tmp_path / "out"
    _ours(out, "first")
    a = folder_mod.OutputFolder(out, overwrite=True)
    b = folder_mod.OutputFolder(out, overwrite=True)
    b.tmp = tmp_path / ".out.tmp-1"          # another process: another name
    a.write_text("results.json", "a")
    b.write_text("results.json", "b")
    pending = [b]

    def then_b(real):
        def step(*args):
            done = real(*args)
            if pending:                      # B commits right after A's first step
                pending.pop().commit()
            return done
        return step
    if hasattr(folder_mod, "exchange"):
        monkeypatch.setattr(folder_mod, "exchange", then_b(folder_mod.exchange))
    monkeypatch.setattr(Path, "rename", then_b(Path.rename))
    monkeypatch.setattr(os, "rename", then_b(os.rename))
    a.commit()
    assert not pending
    assert (out / "results.json").read_text() == "b"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


# --- 9. messages that misled -------------------------------------------------------------------

def test_tiny_level_set_solves(tmp_path):
    """level_set = "1e-300*(y-5.1)" said "crosses cell 200 ... 0 times: refine the mesh"."""
    case = write_case(tmp_path, edited(CONTACT, (CIRCLE, 'level_set = "1e-300*(y-5.1)"')))
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    r = results(out)
    assert r["converged"] and r["geometry"]["cut_cells"] == 8


def test_huge_level_set_without_numpy_warnings(tmp_path):
    """level_set = "1e300*(y-5.1)" printed NumPy's RuntimeWarnings (overflow) on stderr."""
    case = write_case(tmp_path, edited(CONTACT, (CIRCLE, 'level_set = "1e300*(y-5.1)"')))
    proc = run_cli(["run", case, "-o", tmp_path / "out"], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stderr == ""


def test_small_closed_circle_in_one_cell(tmp_path):
    """Was "does not meet the domain" (and solved without interface)."""
    from xfemcontact.errors import GeometryError

    with pytest.raises(GeometryError) as info:
        checked(tmp_path, edited(CONTACT, (CIRCLE, 'level_set = "(x-5.6)**2 + (y-5.6)**2 - 0.04"')))
    assert str(info.value) == (f"{tmp_path}/case.toml: interface.level_set: the interface makes a "
                               f"closed curve inside cell 36 near (5.625, 5.625), smaller than the "
                               f"cell (LN > 0 at its nodes, the other sign inside): refine the "
                               f"mesh there")


def test_extreme_mesh_size_refused(tmp_path):
    from xfemcontact.errors import CaseError

    with pytest.raises(CaseError, match=r"mesh.rectangle: the mesh is 1e\+200 m across"):
        checked(tmp_path, edited(CONTACT, ("x = [0.0, 10.0], y = [0.0, 10.0]",
                                           "x = [0.0, 1e200], y = [0.0, 1e200]"),
                                 (CIRCLE, 'level_set = "y - 5.1e199"')))


def test_max_error_test_without_interface_points(tmp_path):
    """Issue 18 point 4: a RELATIF MAX_ERROR test on an interface field of a level set that does
    not meet the domain ended in a TypeError traceback (exit 1); now NOOK, "no point selected"."""
    text = edited(CONTACT, (CIRCLE, 'level_set = "y + 1"'),
                  ("plots = false", 'plots = false\n[reference]\nLAGS_C = "-0.1"\n[[test]]\n'
                                    'field = "LAGS_C"\ntype = "MAX_ERROR"\ntolerance = 0.1'))
    case = write_case(tmp_path, text)
    proc = run_cli(["run", case, "-o", tmp_path / "out"], timeout=TIMEOUT)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    assert any(line.startswith("NOOK") and "no point selected" in line
               for line in proc.stdout.splitlines())


ONE_CELL = """\
title = "one cell"
[mesh]
rectangle = { nx = 1, ny = 1, x = [0.0, 1.0], y = [0.0, 1.0], cell = "QUAD8" }
[material]
E = 1.0e6
nu = 0.3
[[dirichlet]]
group = "bottom"
DX = 0.0
DY = 0.0
[[traction]]
group = "top"
FY = -1.0
[[test]]
field = "SIYY"
type = "MIN"
reference = -1.0
tolerance = 0.1
criterion = "ABSOLU"
[output]
plots = false
"""


@pytest.mark.mpi
@pytest.mark.parametrize("np_", [2, 3])
def test_more_processes_than_cells(tmp_path, run_once, np_):
    """A process without cells skipped a collective call (the job hung forever) and then
    had no stress samples for the tests (a traceback); it now takes part with nothing."""
    case = run_once.case(ONE_CELL)
    one, one_out = run_once(case)              # one process: shared by both parameters
    many = run_cli(["run", case, "-o", tmp_path / "many"], np=np_, timeout=TIMEOUT)
    assert one.returncode == 0 and many.returncode == 0, many.stdout + many.stderr
    a, b = results(one_out), results(tmp_path / "many")
    assert b["processes"] == np_
    assert a["tests"][0]["value"] == pytest.approx(b["tests"][0]["value"], rel=1e-12, abs=1e-12)
