"""When something goes wrong (issue 7): bad input refused before any heavy work in one
line naming the culprit (exit 2), no convergence (exit 3, results.json with
"converged": false and diagnostics), no code execution from case files, output
folders complete or absent when a run is killed (SIGTERM / SIGINT).

The messages checked here are the ones listed in docs/errors.md.  Bad inputs
already covered by tests/test_cli.py and tests/test_case.py (unknown keys, wrong
types, missing groups, missing mesh file, ranges at load time) are not repeated.
"""
import json
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import ENV, ROOT, results, run_cli, write_case

GOOD = (ROOT / "tests" / "data" / "cases" / "elastic_rectangle.toml").read_text()
TIMEOUT = 120

# an SSNV509-like frictional contact case on 8 x 8 QUAD8, quick to solve
CONTACT = """\
title = "low friction, 8 x 8"
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
contact_init = "OUI"
seuil_init = -5.0
iter_cont_maxi = 30
iter_frot_maxi = 30
[newton]
resi_glob_rela = 1.0e-9
[output]
plots = false
[[test]]
field = "LAGS_C"
type = "MIN"
reference = -0.1
tolerance = 1.0
criterion = "ABSOLU"
"""
P1_DX = '[[dirichlet]]\ngroup = "P1"\nDX = 0.0\n'
LIG1_DY = '[[dirichlet]]\ngroup = "LIG1"\nDY = 0.0\n'
LIG3_DXDY = '[[dirichlet]]\ngroup = "LIG3"\nDX = 0.0\nDY = -1.0e-6\n'
CIRCLE = 'level_set = "(x-xc)**2 + (y-yc)**2 - 64.27"'


def edited(text, *edits):
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def listing(directory):
    return sorted(str(p.relative_to(directory)) for p in directory.rglob("*"))


def one_line(proc):
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    return lines[0]


# --- meshes that cannot be used ---------------------------------------------------------------

def _rectangle_points_cells():
    from xfemcontact.mesh.generate import rectangle

    r = rectangle(2, 2)
    return r.points.copy(), r.cells.copy()


def _write_vtu(path, points, cells, cell_type):
    import meshio

    meshio.write(path, meshio.Mesh(np.c_[points, np.zeros(len(points))], [(cell_type, cells)]))


def make_mesh(folder, kind):
    """A bad mesh file of ``kind`` in ``folder``; returns its name."""
    if kind == "garbage.msh":
        (folder / kind).write_text("this is not a mesh\n")
    elif kind == "mesh.stl":
        (folder / kind).write_text("solid nothing\n")
    elif kind == "linear.vtu":
        pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]])
        _write_vtu(folder / kind, pts, np.array([[0, 1, 2], [0, 2, 3]]), "triangle")
    elif kind == "degenerate.vtu":
        pts, cells = _rectangle_points_cells()
        pts[cells[0, 2]] = pts[cells[0, 0]]           # a corner on the opposite one
        _write_vtu(folder / kind, pts, cells, "quad8")
    elif kind == "inverted.vtu":
        pts, cells = _rectangle_points_cells()
        a, b, mid = cells[0, 0], cells[0, 1], cells[0, 4]
        pts[mid] = pts[a] + 0.95 * (pts[b] - pts[a])  # mid-node beyond the quarter point
        _write_vtu(folder / kind, pts, cells, "quad8")
    return kind


MESH_CASES = {
    # mesh file: what the one line must contain
    "garbage.msh": ["mesh.file", "garbage.msh", "cannot read as Gmsh"],
    "mesh.stl": ["mesh.file", "mesh.stl", "unknown mesh format '.stl'", "supported: .med"],
    "linear.vtu": ["mesh.file", "linear.vtu", "unsupported 2-D cells triangle x2",
                   "supported: exactly one of quad8 (QUAD8), triangle6 (TRIA6)", "quadratic"],
    "degenerate.vtu": ["mesh.file", "degenerate.vtu", "cell 0 (QUAD8",
                       "degenerate or inverted"],
    "inverted.vtu": ["mesh.file", "inverted.vtu", "cell 0 (QUAD8", "degenerate or inverted"],
}


@pytest.mark.parametrize("kind", sorted(MESH_CASES))
def test_bad_mesh_file(tmp_path, kind):
    name = make_mesh(tmp_path, kind)
    case = write_case(tmp_path, edited(GOOD, ("rectangle = { nx = 4, ny = 4 }",
                                              f'file = "{name}"')))
    before = listing(tmp_path)
    proc = run_cli(["run", case, "-o", tmp_path / "out"], timeout=TIMEOUT)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    line = one_line(proc)
    assert line.startswith(f"error: {case}: "), line
    for part in MESH_CASES[kind]:
        assert part in line, (part, line)
    assert listing(tmp_path) == before


# --- bad values, units, formulas evaluated at nodes, level sets, supports -----------------------

BAD = {
    # name: (base text, edits, what the one line must contain)
    "E-with-unit": (GOOD, [("E = 2.0e11", 'E = "210 GPa"')],
                    ['material.E: expected a number, got "210 GPa" (write numbers without '
                     'units, in Pa: 2.1e+11)']),
    "DX-with-unit": (GOOD, [('group = "P1"\nDX = 0.0', 'group = "P1"\nDX = "2 mm"')],
                     ['dirichlet[1].DX: expected a number or a formula, got "2 mm" (write '
                      'numbers without units, in m: 0.002)']),
    "E-negative": (GOOD, [("E = 2.0e11", "E = -2.0e11")],
                   ["material.E: must be > 0, got -200000000000.0"]),
    "nu-too-large": (GOOD, [("nu = 0.3", "nu = 0.5")],
                     ["material.nu: must be > -1 and < 0.5, got 0.5"]),
    "mu-negative": (CONTACT, [("coulomb = 0.3", "coulomb = -0.3")],
                    ["contact.coulomb: must be >= 0, got -0.3"]),
    "coef_cont-zero": (CONTACT, [("coef_cont = 1.0e6", "coef_cont = 0")],
                       ["contact.coef_cont: must be > 0, got 0"]),
    "coef_frot-negative": (CONTACT, [("coef_frot = 1000.0", "coef_frot = -1000.0")],
                           ["contact.coef_frot: must be > 0, got -1000.0"]),
    "ordre_int-too-large": (CONTACT, [("[newton]", "ordre_int = 12\n[newton]")],
                            ["contact.ordre_int: must be >= 1 and <= 8, got 12"]),
    "misspelled-contact-key": (CONTACT, [("coef_frot = 1000.0", "coef_frott = 1000.0")],
                               ["contact.coef_frott: unknown key (did you mean 'coef_frot'?)"]),
    "formula-syntax": (GOOD, [('DY = "5e-6*y"', 'DY = "5e-6*"')],
                       ["reference.DY: syntax error at the end: invalid syntax"]),
    "formula-unknown-function": (GOOD, [('DY = "5e-6*y"', 'DY = "5e-6*sqr(y)"')],
                                 ["reference.DY: unknown function 'sqr' (did you mean 'sqrt'?)"]),
    "dirichlet-division-by-zero": (GOOD, [('group = "P1"\nDX = 0.0',
                                           'group = "LIG3"\nDX = "1e-6/(x-10)"')],
                                   ["dirichlet[1].DX: division by zero or invalid value at "
                                    "x=10, y=10"]),
    "level-set-nan": (CONTACT, [(CIRCLE, 'level_set = "sqrt(x - 5)"')],
                      ["interface.level_set: division by zero or invalid value at x=0, y=0"]),
    "level-set-division-by-zero": (CONTACT, [(CIRCLE, 'level_set = "1/(x - 5) - 1"')],
                                   ["interface.level_set: division by zero or invalid value "
                                    "at x=5, y=0"]),
    "level-set-crack": (CONTACT, [(CIRCLE, 'level_set = "(y - 5)**2 * sign(x - 5)"')],
                        ["interface.level_set: LN = 0 along 8 edge(s) without changing sign "
                         "(LN < 0 on both sides), first near (0.625, 5)",
                         "cracks and interfaces ending inside the domain are not supported"]),
    "level-set-zero-cell": (CONTACT, [(CIRCLE, 'level_set = "min(x - 5, 0) * (y - 3)"')],
                            ["interface.level_set: LN = 0 at every node of cell 4 near "
                             "(5.625, 0.625)"]),
    "rigid-no-DX": (GOOD, [(P1_DX, "")],
                    ["dirichlet: rigid-body motion not prevented: nothing imposes DX "
                     "(translation in x is free): impose DX somewhere"]),
    "rigid-rotation": (GOOD, [(LIG1_DY, '[[dirichlet]]\ngroup = "P1"\nDY = 0.0\n')],
                       ["dirichlet: rigid-body motion not prevented: rotation is free: DX is "
                        "imposed only at y = 0 (P1) and DY only at x = 0 (P1); impose DX at "
                        "another y, or DY at another x"]),
    "rigid-nothing": (GOOD, [(LIG1_DY, ""), (P1_DX, "")],
                      ["dirichlet: rigid-body motion not prevented: nothing imposes DX or DY "
                       "(translations in x and y and rotation are free): impose DX and DY "
                       "somewhere"]),
    "rigid-free-side": (CONTACT, [('law = "contact"', 'law = "free"'),
                                  (LIG3_DXDY, '[[traction]]\ngroup = "LIG3"\nFY = -1.0\n')],
                        ["dirichlet: rigid-body motion not prevented for the part on the "
                         "LN < 0 side of the interface",
                         'with law = "free" each side is a separate body',
                         "nothing imposes DX or DY"]),
    "rigid-free-side-DX": (CONTACT, [('law = "contact"', 'law = "free"'),
                                     (CIRCLE, 'level_set = "y - 5.3"'),
                                     ("DX = 0.0\nDY = -1.0e-6", "DY = -1.0e-6")],
                           ["rigid-body motion not prevented for the part on the LN > 0 side",
                            "nothing imposes DX (translation in x is free)"]),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_input_one_line_exit_2(tmp_path, name):
    base, edits, expected = BAD[name]
    case = write_case(tmp_path, edited(base, *edits), f"{name}.toml")
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out], timeout=TIMEOUT)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    line = one_line(proc)
    assert line.startswith(f"error: {case}: "), line
    for part in expected:
        assert part in line, (part, line)
    assert "dofs on" not in proc.stdout               # refused before the set-up
    assert listing(tmp_path) == [case.name]


def test_level_set_outside_the_domain_warns_and_solves(tmp_path):
    text = edited(CONTACT, (CIRCLE, 'level_set = "y + 1"'))
    case = write_case(tmp_path, text)
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out], timeout=TIMEOUT)
    expected = (f"warning: {case}: interface.level_set: the interface does not meet the domain "
                f"(LN > 0 at every node, from 1 to 11): solving without interface")
    assert expected in proc.stderr.splitlines(), proc.stderr
    assert proc.returncode == 1, proc.stdout + proc.stderr        # the LAGS_C test: no samples
    r = results(out)
    assert r["converged"] is True
    assert r["dofs"]["LAGS_C"] == 0 and r["dofs"]["heaviside"] == 0
    assert expected.removeprefix("warning: ") in r["warnings"]
    assert r["tests"][0]["samples"] == 0 and r["tests"][0]["ok"] is False
    # said in words, and results.json stays strict JSON (no NaN / Infinity)
    assert any(line.startswith("NOOK") and "no point selected" in line for line in proc.stdout.splitlines())
    strict = json.loads((out / "results.json").read_text(),
                        parse_constant=lambda c: pytest.fail(f"results.json holds {c}"))
    assert strict["tests"][0]["value"] is None and strict["tests"][0]["error"] is None


def test_level_set_touching_the_domain_warns(tmp_path):
    case = write_case(tmp_path, edited(CONTACT, (CIRCLE, 'level_set = "-(y - 5)**2"')))
    proc = run_cli(["run", case, "-o", tmp_path / "out"], timeout=TIMEOUT)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert (f"warning: {case}: interface.level_set: the interface only touches the domain "
            f"(LN <= 0 at every node, LN = 0 at 17 node(s), near (0, 5); no side with LN > 0): "
            f"solving without interface") in proc.stderr


def test_body_held_by_contact_only_is_accepted(tmp_path):
    """With law = "contact" the interface counts as a connection: the upper block, held
    by contact and friction only (its top edge loaded, not fixed), is solved."""
    text = edited(CONTACT, (LIG3_DXDY, '[[traction]]\ngroup = "LIG3"\nFY = -1.0\n'))
    case = write_case(tmp_path, text)
    proc = run_cli(["run", case, "-o", tmp_path / "out"], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "rigid-body" not in proc.stderr


# --- no code execution from case files -------------------------------------------------------

HOSTILE = {
    "import": ("__import__('os').system('touch pwned')", "attribute access is not allowed"),
    "import-call": ("__import__('os')", "unknown function '__import__'"),
    "eval": ("eval('1')", "unknown function 'eval'"),
    "attribute": ("x.__class__.__bases__", "attribute access is not allowed"),
    "subscript": ("y[0]", "subscripts are not allowed"),
    "lambda": ("(lambda: 1)()", "lambda is not allowed"),
    "comprehension": ("[x for x in [y]]", "comprehensions are not allowed"),
    "generator": ("sum(x for x in [y])", "unknown function 'sum'"),
    "walrus": ("(z := 1)", "assignment expressions (:=) are not allowed"),
    "f-string": ("f'{x}'", "f-strings are not allowed"),
    "long": ("x+" * 50000 + "x", "formula too long (100001 characters, limit 2000)"),
    "nested": ("(" * 200 + "x" + ")" * 200, "formula nested too deeply"),
    "huge-power": ("9**9**9**9", "division by zero, overflow or invalid value"),
}


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_hostile_formula_refused_end_to_end(tmp_path, name):
    text, fragment = HOSTILE[name]
    value = json.dumps(text)                       # a TOML basic string
    case = write_case(tmp_path, GOOD.replace('DX = "-0.3*5e-6*x"', f"DX = {value}"))
    t0 = time.perf_counter()
    proc = run_cli(["run", case, "-o", tmp_path / "out"], timeout=TIMEOUT, cwd=tmp_path)
    elapsed = time.perf_counter() - t0
    assert proc.returncode == 2, proc.stdout + proc.stderr
    line = one_line(proc)
    assert f"{case}: reference.DX: " in line and fragment in line, line
    assert elapsed < 30                             # refused at once, whatever the text
    assert listing(tmp_path) == ["case.toml"]       # nothing ran: no file "pwned"


# --- no convergence: exit 3, results.json with "converged": false ----------------------------

def _run_not_converged(tmp_path, text, *options):
    case = write_case(tmp_path, text)
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out, *options], timeout=TIMEOUT)
    assert proc.returncode == 3, proc.stdout + proc.stderr
    line = one_line(proc)
    assert line.startswith(f"error: {case}: no convergence: "), line
    assert f"see {out}/results.json" in line
    assert "NOT CONVERGED" in proc.stdout
    assert not re.search(r"^(OK|NOOK)\s", proc.stdout, re.M)      # no test table
    r = results(out)
    assert r["converged"] is False and r["reason"] < 0
    assert r["tests"] == [] and "not evaluated" in r["tests_skipped"]
    d = r["diagnostics"]
    assert d["message"] == line.removeprefix("error: ")
    assert d["last_residuals"] and all(np.isfinite(d["last_residuals"]))
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]   # no temporary folder
    return line, d


def test_newton_not_converged(tmp_path):
    text = edited(CONTACT, ("resi_glob_rela = 1.0e-9",
                            "resi_glob_rela = 1.0e-9\niter_glob_maxi = 1"))
    line, d = _run_not_converged(tmp_path, text)
    assert d["loop"] == "newton" and d["reason_name"] == "DIVERGED_INNER"
    assert "Newton did not converge in ITER_GLOB_MAXI = 1 iterations" in line
    assert re.search(r"last residuals \S+, \S+ \(relative to the loads: \S+\)", line), line
    assert "point(s) changed contact status at the last status iteration" in line
    assert d["status_changes"] is not None


PULLED_OFF = """\
title = "upper block pulled off, held by the interface only"
[mesh]
rectangle = { nx = 12, ny = 8, x = [0.0, 3.0], y = [0.0, 2.0], cell = "QUAD8" }
[material]
E = 1.0e6
nu = 0.3
[[dirichlet]]
group = "bottom"
DX = 0.0
DY = 0.0
[[traction]]
group = "top"
FY = 10.0
[interface]
level_set = "y - 0.25*x - 0.6"
[contact]
frottement = "COULOMB"
coulomb = 0.5
coef_cont = 1.0e6
coef_frot = 1.0e3
seuil_init = -5.0
[newton]
resi_glob_rela = 1.0e-10
[output]
plots = false
"""


def test_singular_newton_is_not_told_to_iterate_more(tmp_path):
    """A block pulled off the interface is free once it opens: Newton's residual ends far
    above the loads, and the message names a singular tangent, not iter_glob_maxi."""
    line, d = _run_not_converged(tmp_path, PULLED_OFF)
    assert d["loop"] == "newton" and d["relative_residuals"][-1] > 1.0
    assert "the tangent is probably singular" in line and "raise iter_glob_maxi" not in line


def test_friction_loop_not_converged(tmp_path):
    line, d = _run_not_converged(tmp_path, edited(CONTACT, ("iter_frot_maxi = 30",
                                                            "iter_frot_maxi = 1")))
    assert d["loop"] == "friction" and d["reason_name"] == "DIVERGED_MAX_IT"
    assert ("friction thresholds still changing after ITER_FROT_MAXI = 1 iterations "
            "(relative change 1 > RESI_FROT = 0.0001); raise iter_frot_maxi") in line
    assert d["threshold_change"] == 1.0


def test_contact_loop_not_converged_without_friction(tmp_path):
    # the status loop's own statuses: with the threshold fixed point (with Coulomb's law in
    # Newton, the 2-D default, Newton changes them and the loop converges at once)
    text = edited(CONTACT, ("iter_cont_maxi = 30", "iter_cont_maxi = 1"),
                  ('frottement = "COULOMB"', 'frottement = "SANS"'))
    line, d = _run_not_converged(tmp_path, text, "-xfc_friction_newton", "TRESCA")
    assert d["loop"] == "contact"
    assert "contact statuses still changing after ITER_CONT_MAXI = 1 iterations" in line
    assert f"{d['status_changes']} point(s) changed contact status" in line
    assert d["status_changes"] > 0


def test_mumps_failure(tmp_path):
    # a memory limit of 1 MB per process makes MUMPS fail at factorisation (INFOG(1) = -19)
    # on 40 x 40 cells (about 10 000 dofs)
    bigger = edited(GOOD, ("rectangle = { nx = 4, ny = 4 }", "rectangle = { nx = 40, ny = 40 }"))
    line, d = _run_not_converged(tmp_path, bigger, "-mat_mumps_icntl_23", "1")
    assert d["loop"] == "linear solver"
    assert d["linear_solver"]["mumps_infog1"] == -19
    assert "the linear solver failed (DIVERGED_PCSETUP_FAILED, MUMPS INFOG(1) = -19)" in line
    assert "raise it" in line


def test_mumps_short_of_work_space_is_given_more(tmp_path):
    # a negative work space increase (-99 %) leaves MUMPS short of work space (INFOG(1) = -9);
    # ICNTL(14) is doubled from at least 10 %: at 20 % the run converges, with a warning
    case = write_case(tmp_path, GOOD)
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out, "-mat_mumps_icntl_14", "-99"], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "-mat_mumps_icntl_14 was raised to 20 %" in proc.stderr


def test_forced_contact_convergence_with_friction_is_a_warning(tmp_path):
    """code_aster's CONTACT3_86: ITER_CONT_MAXI reached with friction -> warning, not error.
    (Full steps: with the default line search this case needs no status iteration after
    Newton and nothing is forced.)"""
    text = edited(CONTACT, ("iter_cont_maxi = 30", "iter_cont_maxi = 1"),
                  ('contact_init = "OUI"', 'contact_init = "NON"'),
                  ("coulomb = 0.3", "coulomb = 2.0"), ("coef_cont = 1.0e6", "coef_cont = 100.0"))
    case = write_case(tmp_path, text)
    out = tmp_path / "out"
    proc = run_cli(["run", case, "-o", out, "-xfc_friction_line_search", "NONE"], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    warnings = [line for line in proc.stderr.splitlines() if line.startswith("warning: ")]
    assert warnings and all("convergence forced, as code_aster does with friction "
                            "(alarm CONTACT3_86)" in w for w in warnings), proc.stderr
    r = results(out)
    assert r["converged"] is True
    assert [f"warning: {w}" for w in r["warnings"]] == warnings


# --- interrupted runs: complete previous results or none --------------------------------------

BIG = edited(GOOD, ("nx = 4, ny = 4", "nx = 200, ny = 200"))


def _start(case, out, *extra):
    cmd = [sys.executable, "-m", "xfemcontact", "run", str(case), "-o", str(out), *extra]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=ENV, cwd=ROOT)


def _when(predicate, proc, limit=TIMEOUT):
    t0 = time.monotonic()
    while not predicate():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() - t0 < limit
        time.sleep(0.005)


def _interrupt_while_writing(tmp_path, sig, *extra):
    case = write_case(tmp_path, BIG)
    out = tmp_path / "out"
    proc = _start(case, out, *extra)
    # the temporary folder appears when the output phase starts writing
    _when(lambda: any(p.name.startswith(".out.tmp-") for p in tmp_path.iterdir()), proc)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=TIMEOUT)
    return proc.returncode, stderr, out


def test_sigterm_while_writing_leaves_nothing(tmp_path):
    code, stderr, out = _interrupt_while_writing(tmp_path, signal.SIGTERM)
    assert code == 143, stderr
    assert stderr.strip() == "interrupted (SIGTERM): no results written"
    assert listing(tmp_path) == ["case.toml"]


def test_sigterm_with_overwrite_keeps_previous_results(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.json").write_text('{"xfemcontact": "0.1.0", "previous": true}\n')
    code, stderr, out = _interrupt_while_writing(tmp_path, signal.SIGTERM, "--overwrite")
    assert code == 143, stderr
    assert stderr.strip() == f"interrupted (SIGTERM): previous results in {out} kept"
    assert listing(tmp_path) == ["case.toml", "out", "out/results.json"]
    assert json.loads((out / "results.json").read_text())["previous"] is True


def test_sigint_while_solving(tmp_path):
    case = write_case(tmp_path, BIG)
    out = tmp_path / "out"
    proc = _start(case, out)
    assert "dofs on 1 process(es)" in proc.stdout.readline()     # set up, solving now
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=TIMEOUT)
    assert proc.returncode == 130, stderr
    assert stderr.strip() == "interrupted (SIGINT): no results written"
    assert listing(tmp_path) == ["case.toml"]


def test_interrupt_during_commit_is_held_back(tmp_path):
    """A signal received while the folder is renamed into place waits until it is done."""
    import os

    from xfemcontact.errors import Interrupted
    from xfemcontact.output import folder as folder_mod

    out = tmp_path / "out"
    out.mkdir()
    (out / "results.json").write_text('{"xfemcontact": "0.1.0"}')     # earlier results of ours
    f = folder_mod.OutputFolder(out, overwrite=True)
    f.write_text("results.json", "{}")
    previous = folder_mod.handle_signals()
    try:
        real_exchange = folder_mod.exchange

        def exchange_then_signal(a, b):     # the signal comes while the folders are swapped
            real_exchange(a, b)
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.05)
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(folder_mod, "exchange", exchange_then_signal)
            with pytest.raises(Interrupted) as info:
                f.commit()
        assert info.value.exit_code == 143
        assert f.outcome() == f"complete results in {out} (the run had finished)"
        assert listing(tmp_path) == ["out", "out/.xfemcontact", "out/results.json"]
        assert (out / "results.json").read_text() == "{}"
    finally:
        folder_mod.restore_signals(previous)


# --- MPI: errors found at nodes are reported once, without a hang -------------------------------

@pytest.mark.mpi
def test_node_errors_under_mpirun(tmp_path):
    """A formula failing at a node of one process only, and a rigid-body refusal, under
    mpirun -n 2: one line, exit code 2, no hang (the checks run before distribution)."""
    for name in ("dirichlet-division-by-zero", "rigid-no-DX"):
        base, edits, expected = BAD[name]
        case = write_case(tmp_path, edited(base, *edits), f"{name}.toml")
        proc = run_cli(["run", case, "-o", tmp_path / "out"], np=2, timeout=TIMEOUT)
        assert proc.returncode == 2, proc.stdout + proc.stderr
        ours = [line for line in proc.stderr.splitlines() if line.startswith("error: ")]
        assert len(ours) == 1 and expected[0] in ours[0], proc.stderr
        assert not (tmp_path / "out").exists()


# --- the checks on their own ---------------------------------------------------------------------

def _case(tmp_path, text):
    from xfemcontact.case import load_case

    return load_case(write_case(tmp_path, text))


def _rigid(tmp_path, text):
    from xfemcontact import preflight

    case = _case(tmp_path, text)
    return preflight.preflight(case, preflight.build_mesh(case))


@pytest.mark.parametrize("law", ["contact", "bonded"])
def test_connected_interface_laws_make_one_body(tmp_path, law):
    from xfemcontact.errors import CaseError

    text = edited(CONTACT, ('law = "contact"', f'law = "{law}"'),
                  (LIG3_DXDY, '[[traction]]\ngroup = "LIG3"\nFY = -1.0\n'))
    assert _rigid(tmp_path, text).warnings == []
    with pytest.raises(CaseError, match="LN < 0 side"):
        _rigid(tmp_path, text.replace(f'law = "{law}"', 'law = "free"'))


def test_free_interface_sides_held_separately(tmp_path):
    """Each side held on its own edge: accepted; DY alone on two points of one side: the
    rotation is held but not the x translation."""
    from xfemcontact.errors import CaseError

    text = edited(CONTACT, ('law = "contact"', 'law = "free"'))
    assert _rigid(tmp_path, text).warnings == []
    text = edited(text, ("DX = 0.0\nDY = -1.0e-6", "DY = -1.0e-6"))
    with pytest.raises(CaseError, match=r"LN < 0 side .*nothing imposes DX \(translation in x "
                                        r"is free\)"):
        _rigid(tmp_path, text)


def test_heaviside_dofs_of_a_node_group_on_the_interface_hold_both_sides(tmp_path):
    """A free interface along the diagonal x + y = 10 through the corners P2 and P4: DX at
    P4 alone holds both sides (the Heaviside dofs of a node group are imposed too)."""
    from xfemcontact.errors import CaseError

    text = edited(CONTACT, ('law = "contact"', 'law = "free"'),
                  (CIRCLE, 'level_set = "x + y - 10"'),
                  (LIG3_DXDY, '[[dirichlet]]\ngroup = "LIG3"\nDY = -1.0e-6\n'),
                  ('group = "LIG1"\nDX = 0.0\nDY = 0.0', 'group = "LIG1"\nDY = 0.0'))
    with pytest.raises(CaseError, match="nothing imposes DX"):
        _rigid(tmp_path, text)
    assert _rigid(tmp_path, text + '[[dirichlet]]\ngroup = "P4"\nDX = 0.0\n').warnings == []
    # an edge group that does not reach the interface holds its own side only
    text = edited(text, ('level_set = "x + y - 10"', 'level_set = "x + y - 10.3"'),
                  ('group = "LIG1"\nDY = 0.0', 'group = "LIG1"\nDX = 0.0\nDY = 0.0'))
    with pytest.raises(CaseError, match=r"LN > 0 side .*nothing imposes DX"):
        _rigid(tmp_path, text)


def test_levelset_meets_domain_function():
    from xfemcontact.preflight import levelset_meets_domain

    assert levelset_meets_domain(np.array([-1.0, 2.0])) is None
    assert "does not meet the domain (LN < 0 at every node" in \
        levelset_meets_domain(np.array([-1.0, -2.0]))
    message = levelset_meets_domain(np.array([0.0, 2.0]), np.array([[1.0, 2.0], [3.0, 4.0]]),
                                    source="c.toml")
    assert message == ("c.toml: interface.level_set: the interface only touches the domain "
                       "(LN >= 0 at every node, LN = 0 at 1 node(s), near (1, 2); no side with "
                       "LN < 0): solving without interface")


def test_level_set_field_of_the_mesh_file(tmp_path):
    """interface.level_set_field: missing, not finite, of one sign (checked like a formula)."""
    from xfemcontact import preflight
    from xfemcontact.errors import MeshError
    from xfemcontact.mesh.generate import rectangle

    mesh = ROOT / "cases" / "meshes" / "ssnv509a.mmed"
    text = edited(CONTACT, ("rectangle = { nx = 8, ny = 8, x = [0.0, 10.0], y = [0.0, 10.0], "
                            'cell = "QUAD8" }', f'file = "{mesh}"'),
                  (CIRCLE, 'level_set_field = "LSN"'))
    case = _case(tmp_path, text)
    raw = rectangle(8, 8)
    raw.source = "m.med"
    with pytest.raises(MeshError, match=r"interface.level_set_field: no nodal field 'LSN' in "
                                        r"m.med \(nodal fields: none\)"):
        preflight.preflight(case, raw)
    x, y = raw.points.T
    raw.point_data = {"LSN": (x - 5) ** 2 + (y - 11.77) ** 2 - 64.27}
    assert preflight.preflight(case, raw).warnings == []
    raw.point_data["LSN"][7] = np.nan
    with pytest.raises(MeshError, match=r"'LSN' is not finite at node 7 \("):
        preflight.preflight(case, raw)
    raw.point_data["LSN"] = y + 1
    pre = preflight.preflight(case, raw)
    assert not pre.interface
    assert pre.warnings == [f"{case.source}: interface.level_set_field: the interface does not "
                            f"meet the domain (LN > 0 at every node, from 1 to 11): solving "
                            f"without interface"]


def test_mumps_parallel_analysis_without_its_ordering_says_so(tmp_path):
    # Debian's MUMPS has neither PT-Scotch nor ParMETIS for its parallel analysis: INFOG(1)
    # = -38, which the message now explains
    line, d = _run_not_converged(tmp_path, CONTACT, "-mat_mumps_icntl_28", "2", "-mat_mumps_icntl_29", "1")
    assert d["linear_solver"]["mumps_infog1"] == -38
    assert "MUMPS INFOG(1) = -38): the parallel analysis (-mat_mumps_icntl_28 2) needs PT-Scotch" in line


def test_superlu_dist_factorises_a_contact_case(tmp_path):
    # SuperLU_DIST pivots statically: the zero diagonal block of the contact multipliers
    # stopped it (DIVERGED_PCSETUP_FAILED) until tiny pivots were replaced by default
    out = tmp_path / "out"
    text = edited(CONTACT, ('frottement = "COULOMB"', 'frottement = "SANS"'))
    proc = run_cli(["run", write_case(tmp_path, text), "-o", out, "-pc_type", "lu",
                    "-pc_factor_mat_solver_type", "superlu_dist"], timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    r = results(out)
    assert r["linear_solver"]["solver"] == "superlu_dist" and all(t["ok"] for t in r["tests"])
