"""Frictional contact on the interface (issue 4): SSNV509 a and b, beyond stick, stability."""

import dataclasses

import numpy as np
import pytest

from conftest import CASES, ROOT, gauss, inclusion_case, results, run_cli, with_contact_keys

DATA_CASES = ROOT / "tests" / "data" / "cases"

SSNV509 = ["ssnv509a", "ssnv509a_med", "ssnv509b", "ssnv509b_refined"]


def run_ok(case, out, *options):
    """Run ``case`` into ``out``, asserting success; returns the process and results.json."""
    p = run_cli(["run", case, "-o", out, *options])
    assert p.returncode == 0, p.stdout + p.stderr
    return p, results(out)


def shared_ok(run_once, case, *options):
    """``run_ok`` of a one-process run that several tests read (done once, conftest.Runs):
    the process, results.json and the output folder."""
    p, out = run_once(case, *options)
    assert p.returncode == 0, p.stdout + p.stderr
    return p, results(out), out


def exact(x, y, yc=11.77):
    t = np.arctan2(y - yc, x - 5.0)
    return -0.1 * np.sin(t) ** 2, (x - 5.0) / (2.0 * (y - yc))


def pointwise_errors(res):
    it = res["interface"]
    x, y = np.array(it["x"]), np.array(it["y"])
    c, f1 = exact(x, y)
    return np.abs(np.array(it["LAGS_C"]) - c).max(), np.abs(np.array(it["LAGS_F1"]) - f1).max()


@pytest.mark.parametrize("name", SSNV509)
def test_ssnv509_tables_and_null_pivots(tmp_path, name):
    """code_aster's four tests pass; with MUMPS null-pivot detection on, no null pivot."""
    _, r = run_ok(CASES / f"{name}.toml", tmp_path / name, "-mat_mumps_icntl_24", "1")
    assert r["converged"]
    assert all(t["ok"] for t in r["tests"]), r["tests"]
    assert r["linear_solver"]["mumps"]["null_pivots"] == 0
    err_c, err_f = pointwise_errors(r)
    # every tested value beats code_aster's worst errors (SPEC: 4.8e-4 LAGS_C, 3.3e-3 LAGS_F1)
    assert err_c < 4.8e-4 and err_f < 3.3e-3
    assert r["multipliers"]["ties"] <= 1        # curved: at most the flat bottom of the arc
    print(f"{name}: max error LAGS_C {err_c:.2e} LAGS_F1 {err_f:.2e}, iterations {r['iterations']}")


def test_interface_table_layout(run_once):
    it = shared_ok(run_once, CASES / "ssnv509a.toml")[1]["interface"]
    n = len(it["x"])
    assert n > 0 and all(len(it[k]) == n for k in ("y", "LAGS_C", "LAGS_F1", "gap", "slip"))
    # every point appears once per cell holding it: interior points twice
    pts = np.round(np.c_[it["x"], it["y"]], 12)
    _, counts = np.unique(pts, axis=0, return_counts=True)
    assert set(counts) <= {1, 2}
    assert (counts == 2).sum() >= n // 2 - 2


@pytest.mark.parametrize("name", ["opening", "slip_straight", "slip_straight_tria6",
                                  "frictionless", "tangent_circle", "tangent_circle_tria6",
                                  "ellipse_tria6", "inclined_line_tria6", "sinusoid",
                                  "ssnv509_jittered", "ssnv509_distorted_quad8", "inclusion_biaxial",
                                  "flat_arc", "column_on_incline", "column_on_incline_tria6", "inclined_line",
                                  "diagonal_line", "free_lips"])
def test_beyond_stick(run_once, name):
    _, r, _ = shared_ok(run_once, CASES / "validation" / f"{name}.toml")
    assert r["converged"] and all(t["ok"] for t in r["tests"])


def test_beyond_stick_low_friction_noeud(tmp_path):
    """SSNV509 a with mu = 0.3: the friction statuses and thresholds cycled with period 3
    until the threshold iterations cut their status loops while the thresholds were
    far off (solver/loops.py, INEXACT_ITERATIONS)."""
    _, r = run_ok(CASES / "validation" / "low_friction.toml", tmp_path / "lf")
    assert r["converged"] and all(t["ok"] for t in r["tests"])


def test_beyond_stick_low_friction_gauss(tmp_path, run_once):
    """code_aster's Gauss-point form on the same case (its fallbacks included) converges."""
    case = run_once.case(gauss(CASES / "validation" / "low_friction.toml", tmp_path).read_text(), "low_friction.toml")
    _, r, _ = shared_ok(run_once, case)
    assert r["converged"] and all(t["ok"] for t in r["tests"])


def test_free_and_bonded_interfaces_have_an_interface_table(tmp_path):
    """Without multipliers (law free or bonded) the interface points still carry gap and
    slip: the free lips of free_lips.toml interpenetrate by -6e-5 m (tested there), bonded
    ones do not move apart; LAGS_C = LAGS_F1 = 0."""
    text = (CASES / "validation" / "free_lips.toml").read_text()
    for law in ("free", "bonded"):
        case = tmp_path / f"{law}.toml"
        case.write_text(text.replace('law = "free"', f'law = "{law}"').split("[reference]")[0])
        p, r = run_ok(case, tmp_path / law)
        it = r["interface"]
        assert len(it["x"]) == 2 * 12 and (tmp_path / law / "interface.csv").exists()
        gap = np.array(it["gap"])
        assert np.allclose(gap, -6e-5 if law == "free" else 0.0, rtol=0, atol=1e-12)
        assert np.abs(it["slip"]).max() < 1e-12
        assert not np.any(it["LAGS_C"]) and not np.any(it["LAGS_F1"])
        assert set(it["contact"]) == {1.0 if law == "bonded" else 0.0}


@pytest.mark.parametrize("name", ["inclined_line", "column_on_incline", "diagonal_line"])
def test_straight_interfaces_on_quadrangles_have_unique_multipliers(tmp_path, name):
    """The kernel of a straight interface across quadrangles spans rows of cut cells (every
    packet alone is regular): with null-pivot detection on, MUMPS finds none (20 and 1
    before the kernels were looked for across packets).  Along quadrangle diagonals no
    edge interior is crossed and the two corners off the line are twins (12 null pivots
    and a MUMPS failure before twins were merged)."""
    _, r = run_ok(CASES / "validation" / f"{name}.toml", tmp_path / name, "-mat_mumps_icntl_24", "1")
    assert r["linear_solver"]["mumps"]["null_pivots"] == 0
    assert r["multipliers"]["ties"] >= 1


def test_frictionless_start_without_equilibrium_restarts_sticking(tmp_path):
    """A block held only by friction, no SEUIL_INIT: code_aster's frictionless first
    iteration has no solution; it is redone sticking, with a warning, and the closed
    form is reached."""
    p, r = run_ok(gauss(CASES / "validation" / "column_on_incline_tria6.toml", tmp_path), tmp_path / "col")
    assert "held only by friction" in p.stderr + p.stdout
    assert r["converged"] and all(t["ok"] for t in r["tests"])
    assert r["iterations"]["stick_predictor_steps"] == 1


def test_chained_ties_keep_linear_fields(tmp_path):
    """A nearly flat arc ties several neighbouring crossed edges in a row: each gradient
    tie must be written in free carriers (a later tie may take one of its roots).  With
    the chain left unresolved LAGS_F1 was 5.0e-5 off here, 2.5e-5 on SSNV509 a at N = 320."""
    _, r = run_ok(CASES / "validation" / "flat_arc.toml", tmp_path / "flat")
    assert r["multipliers"]["ties"] >= 5
    it = r["interface"]
    x, y = np.array(it["x"]), np.array(it["y"])
    yc = 65.13
    f1 = (x - 5.0) / (2.0 * (y - yc))
    assert np.abs(np.array(it["LAGS_F1"]) - f1).max() < 1e-6


def test_opening_releases_every_point(run_once):
    _, r, _ = shared_ok(run_once, CASES / "validation" / "opening.toml")
    # statuses changed: inside Newton (Coulomb's law in Newton, the default: the semi-smooth
    # Newton updates contact statuses at every iteration) or in the status loop (TRESCA)
    assert r["iterations"]["newton"] > 1 or r["iterations"]["status_changes"][0] > 0
    assert not any(r["interface"]["contact"])


@pytest.mark.parametrize("integration", ["NOEUD", "GAUSS"])
def test_slip_zone_matches_stick_prediction(tmp_path, run_once, integration):
    """mu = 0.3: points where the stick solution needs |sigma_nt| > mu |sigma_nn| slip.
    (GAUSS: the run of test_beyond_stick_low_friction_gauss, the same case file.)"""
    case = with_contact_keys(CASES / "validation" / "low_friction.toml", tmp_path, integration=f'"{integration}"')
    it = shared_ok(run_once, run_once.case(case.read_text(), case.name))[1]["interface"]
    x, y = np.array(it["x"]), np.array(it["y"])
    ratio = np.abs(x - 5.0) / np.abs(y - 11.77)          # |sigma_nt / sigma_nn| of the stick solution
    sliding = np.array(it["sliding"], bool)
    f1 = np.abs(np.array(it["LAGS_F1"]))
    beyond = ratio > 0.3 * 1.2                            # clearly beyond the cone: slip, |F1| = 1
    assert sliding[beyond].all()
    assert np.allclose(f1[beyond], 1.0, atol=1e-5)
    assert (f1 <= 1.0 + 1e-4).all()      # the cone holds at Gauss points; points interpolate
    inside = ratio < 0.3 * 0.5                            # well inside the cone: stick, |F1| < 1
    assert (f1[inside] < 0.9).all()
    if integration == "GAUSS":           # at the dofs a point's status is its cell's: a cell next
        assert (~sliding[inside]).all()  # to a slipping dof reports slip with |F1| < 1
    print(f"sliding points {sliding.sum()} / {len(sliding)}")


def test_symbolic_factorisation_reused(tmp_path):
    """One symbolic factorisation for the whole run, one numeric one per Jacobian
    (default LDL^T, and LU)."""
    for extra, sym, num in (((), "MatCholFctrSym", "MatCholFctrNum"),
                            (("-pc_type", "lu"), "MatLUFactorSym", "MatLUFactorNum")):
        out = tmp_path / sym
        p = run_cli(["run", CASES / "ssnv509a.toml", "-o", out, "-log_view", *extra])
        assert p.returncode == 0
        counts = {}
        for line in p.stdout.splitlines():
            parts = line.split()
            if parts and parts[0] in (sym, num):
                counts[parts[0]] = int(parts[1])
        assert counts[sym] == 1
        assert counts[num] == results(out)["linear_solver"]["jacobians"]


def test_traction_form_needs_one_factorisation(tmp_path):
    """With the tangential traction as unknown, SSNV509's threshold loop does not refactor."""
    out = tmp_path / "t"
    p = run_cli(["run", CASES / "ssnv509a.toml", "-o", out, "-xfc_friction_unknown", "traction"])
    assert p.returncode == 0, p.stdout + p.stderr
    r = results(out)
    assert r["linear_solver"]["jacobians"] == 1
    assert all(t["ok"] for t in r["tests"])


INTERFACE_FIELDS = ("x", "y", "LAGS_C", "LAGS_F1", "gap", "slip")


def one_and_many(tmp_path, case, np_, run_once=None):
    """results.json of ``case`` run on one process and on ``np_`` processes (the one-process
    run shared with the tests that read it too if ``run_once``)."""
    one, many = tmp_path / "one", tmp_path / "many"
    if run_once:
        p, one = run_once(case)
        assert p.returncode == 0, p.stdout + p.stderr
    else:
        assert run_cli(["run", case, "-o", one]).returncode == 0
    p = run_cli(["run", case, "-o", many], np=np_)
    assert p.returncode == 0, p.stdout + p.stderr
    return results(one), results(many)


def assert_same_interface(r1, rn, atol, fields=INTERFACE_FIELDS):
    a, b = r1["interface"], rn["interface"]
    for k in fields:
        assert np.allclose(a[k], b[k], rtol=0, atol=atol), k


def test_failed_factorisation_ends_in_a_clear_error(tmp_path):
    """The raw vertex space (algo_lagr = "NON") on the diagonal line is singular: a Newton
    step meets MUMPS INFOG(1) = -10.  PETSc 3.18 then skips every later numeric
    factorisation of that factor, and the fallbacks (line search, frozen statuses) used to
    stop on MUMPS INFOG(1) = -3 with a traceback.  The failed factor is dropped: each
    fallback factorises anew, and the run ends with exit code 3 and one line naming the
    singular matrix."""
    text = gauss(CASES / "validation" / "diagonal_line.toml", tmp_path).read_text()
    case = tmp_path / "raw.toml"
    case.write_text(text.replace("ordre_int = 4", 'ordre_int = 4\nalgo_lagr = "NON"'))
    out = tmp_path / "raw"
    p = run_cli(["run", case, "-o", out])
    assert p.returncode == 3, p.stdout + p.stderr
    assert "Traceback" not in p.stderr
    errors = [line for line in p.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "linear solver failed" in errors[0] and "INFOG(1) = -10" in errors[0]
    r = results(out)
    assert not r["converged"] and r["diagnostics"]["loop"] == "linear solver"
    assert r["iterations"]["line_search_retries"] == 1


@pytest.mark.mpi
def test_mumps_out_of_work_space_is_given_more(tmp_path):
    """Delayed pivots of the indefinite tangent can exceed MUMPS' workspace estimate
    (INFOG(1) = -9: seen at random on 3 processes with the default relaxation; always
    on 2 processes of this small case with none, -mat_mumps_icntl_14 0).  ICNTL(14) is
    doubled and Newton goes on, with a warning, instead of stopping."""
    text = (CASES / "validation" / "inclined_line.toml").read_text()
    for old, new in (("nx = 20, ny = 20", "nx = 8, ny = 8"), ("a = 0.5", "a = 0.25"), ("b = 2.5", "b = 3.75")):
        assert old in text
        text = text.replace(old, new)
    case = tmp_path / "line.toml"
    case.write_text(text)
    p = run_cli(["run", case, "-o", tmp_path / "out", "-mat_mumps_icntl_14", "0"], np=2)
    assert p.returncode == 0, p.stdout + p.stderr
    r = results(tmp_path / "out")
    assert all(t["ok"] for t in r["tests"])
    assert any("-mat_mumps_icntl_14 was raised to 20 %" in w for w in r["warnings"]), r["warnings"]


@pytest.mark.mpi
def test_mpi_interface_along_quadrangle_diagonals(tmp_path, run_once):
    """Twins are found from gathered data: 2 processes (which crashed before) give the
    exact multipliers of one process."""
    r1, r2 = one_and_many(tmp_path, CASES / "validation" / "diagonal_line.toml", 2, run_once)
    for r in (r1, r2):
        assert r["converged"] and all(t["ok"] for t in r["tests"]), r["tests"]
    assert r1["multipliers"] == r2["multipliers"]
    assert_same_interface(r1, r2, 1e-12)


@pytest.mark.mpi
def test_stick_predictor_holds_a_floating_inclusion(tmp_path):
    """An inclusion held only by contact and friction, no SEUIL_INIT: the first threshold
    iteration is frictionless (its rotation undetermined); the stick predictor lands on
    the stick solution, Newton with the real law starts converged, and 1 and 2
    processes agree."""
    r1, r2 = one_and_many(tmp_path, gauss(CASES / "validation" / "inclusion_biaxial.toml", tmp_path), 2)
    for r in (r1, r2):
        assert r["converged"] and all(t["ok"] for t in r["tests"]), r["tests"]
        it = r["iterations"]
        assert it["stick_predictor_steps"] == 1
        assert it["newton_per_solve"][1] == 0
        assert not any(r["interface"]["sliding"])
    assert_same_interface(r1, r2, 1e-9)         # LAGS_C is about 100 Pa here


@pytest.mark.mpi
def test_failed_full_step_newton_is_redone_with_a_line_search(tmp_path):
    """A nearly free inclusion that slips almost everywhere: full-step Newton stalls in
    the second threshold iteration, the retry with a backtracking line search converges,
    with a warning, on 1 and 2 processes alike."""
    r1, r2 = one_and_many(tmp_path, gauss(DATA_CASES / "inclusion_sliding.toml", tmp_path), 2)
    for r in (r1, r2):
        assert r["converged"]
        assert r["iterations"]["line_search_retries"] == 1
        assert any("line search" in w for w in r["warnings"])
        assert sum(r["interface"]["sliding"]) > 0.8 * len(r["interface"]["sliding"])
    assert_same_interface(r1, r2, 1e-8)


def test_newton_cycling_at_the_stick_slip_limit_ends_with_frozen_statuses(tmp_path):
    """Partial slip on an arc: Newton cycles on points at the stick/slip limit with full
    steps and with a line search; with the friction statuses frozen in Newton and
    updated between solves the loops converge, and |LAGS_F1| <= 1 holds."""
    _, r = run_ok(gauss(DATA_CASES / "arc_partial_slip_tria6.toml", tmp_path), tmp_path / "arc")
    assert r["converged"]
    assert r["iterations"]["frozen_status_solves"] > 0
    it = r["interface"]
    assert 0 < sum(it["sliding"]) < len(it["sliding"])
    sliding = np.array(it["sliding"], bool)
    assert np.allclose(np.abs(np.array(it["LAGS_F1"])[sliding]), 1.0, atol=0.05)


def test_too_small_coef_frot_is_named_when_newton_cycles(tmp_path):
    """Newton cycling at the stick/slip limit with COEF_FROT five orders too small: the
    run stops with a message suggesting COEF_FROT; with the suggested order it converges."""
    case = gauss(DATA_CASES / "arc_small_coef_frot.toml", tmp_path)
    p = run_cli(["run", case, "-o", tmp_path / "small"])
    assert p.returncode != 0
    assert "COEF_FROT = 1000 is small for this problem" in p.stderr
    fixed = tmp_path / "fixed.toml"
    fixed.write_text(case.read_text().replace("coef_frot = 1000.0", "coef_frot = 1.0e8"))
    assert run_ok(fixed, tmp_path / "fixed")[1]["converged"]


@pytest.mark.mpi
def test_mpi_same_interface_values(tmp_path, run_once):
    assert_same_interface(*one_and_many(tmp_path, CASES / "ssnv509a.toml", 2, run_once), 1e-10)


@pytest.mark.mpi
def test_mpi_interface_pushed_off_edges(tmp_path, run_once):
    """The wavy interface touches two mesh edges: the cells along them are cut again
    with the zero line pushed off (a collective retry); 3 processes decide the same
    edges and give the values of one process."""
    r1, r3 = one_and_many(tmp_path, CASES / "validation" / "sinusoid.toml", 3, run_once)
    assert r1["geometry"]["readjusted"] == r3["geometry"]["readjusted"]
    assert r1["geometry"]["readjusted"]["pushed_off_edges"] == 2
    assert sum(c > 0 for c in r3["geometry"]["cut_cells_per_process"]) >= 2
    assert_same_interface(r1, r3, 1e-10)


@pytest.mark.mpi
def test_mpi_distorted_quadrangles(tmp_path, run_once):
    """Distorted QUAD8 cells (maps not affine): each process builds the sub-cells of its
    cut cells, numbered from whichever vertex its DMPlex closure starts at; the fan of
    sub-triangles must not depend on that (their quadrature is not exact on such cells,
    so another fan moves the multipliers by about 1e-10)."""
    r1, r2 = one_and_many(tmp_path, CASES / "validation" / "ssnv509_distorted_quad8.toml", 2, run_once)
    assert all(c > 0 for c in r2["geometry"]["cut_cells_per_process"])
    assert_same_interface(r1, r2, 1e-11)


@pytest.mark.mpi
@pytest.mark.slow
def test_mpi_three_processes_partition_crosses_interface(tmp_path):
    """SSNV509 b refined on 3 processes: the partition boundaries cut the interface (cut
    cells on several processes) and the interface values are those of one process."""
    r1, r3 = one_and_many(tmp_path, CASES / "ssnv509b_refined.toml", 3)
    assert r3["processes"] == 3
    per_process = r3["geometry"]["cut_cells_per_process"]
    assert sum(per_process) == r1["geometry"]["cut_cells"] and sum(c > 0 for c in per_process) >= 2
    for k in ("enriched_nodes", "dropped_heaviside_nodes"):
        assert r3["geometry"][k] == r1["geometry"][k], k
    m1, m3 = r1["multipliers"], r3["multipliers"]
    assert {k: v for k, v in m3.items() if not isinstance(v, float)} == \
        {k: v for k, v in m1.items() if not isinstance(v, float)}
    assert_same_interface(r1, r3, 1e-10, INTERFACE_FIELDS + ("contact", "sliding"))


def test_batched_packet_eigenvalues_match_one_by_one():
    """Packets of several sizes (one singular) solved in batches = solved one at a time."""
    import scipy.sparse as sp
    from xfemcontact.contact import space as cspace

    rng = np.random.default_rng(3)
    sizes = [1, 3, 2, 3, 1, 5, 2]
    blocks = []
    for m in sizes:
        a = rng.normal(size=(m, m + 1))
        blocks.append(a @ a.T)
    v = np.ones(3)
    blocks[2 * 0 + 1] = np.outer(v, v)                    # rank one: a kernel
    G = sp.block_diag(blocks).tocsr()
    perm = rng.permutation(G.shape[0])                    # packets scattered in the numbering
    inv = np.argsort(perm)
    Gp = G[perm][:, perm]
    bounds = np.r_[0, np.cumsum(sizes)]
    order = inv[np.arange(G.shape[0])]
    got = cspace._packet_eigenvalues(Gp.tocsr(), order, bounds)
    want = [cspace._smallest_scaled_eigenvalue(Gp[order[a:b]][:, order[a:b]])
            for a, b in zip(bounds[:-1], bounds[1:])]
    assert np.allclose(got, want, atol=1e-12)
    assert abs(got[1]) < 1e-12 and got.min() == got[1]


@pytest.mark.parametrize("name", ["ssnv509a", "ssnv509b"])
def test_projection_of_a_field_of_the_space_is_exact(name):
    """The L2 projection floor (post.projection) is zero for fields the multiplier
    space holds: an affine LAGS_C and an affine friction unknown (the tangential
    traction mu LAGS_C LAGS_F1 with integration = NOEUD, LAGS_F1 itself with GAUSS)
    come back exactly at every interface point."""
    from xfemcontact.case import load_case
    from xfemcontact.case.formula import compile_formula
    from xfemcontact.model import Model
    from xfemcontact.post.projection import best_errors

    lags_c = "(-0.1 + 0.003*x - 0.002*y)"
    for integration, lags_f1 in (("NOEUD", f"(0.05 + 0.01*x + 0.002*y) / (2*{lags_c})"),
                                 ("GAUSS", "0.25 + 0.05*x + 0.01*y")):
        case = load_case(CASES / f"{name}.toml")
        case = dataclasses.replace(case, contact=dataclasses.replace(case.contact, integration=integration))
        best = best_errors(Model(case), compile_formula(lags_c), compile_formula(lags_f1))
        assert best["LAGS_C"] < 1e-13 and best["LAGS_F1"] < 1e-12, (integration, best)


@pytest.mark.parametrize("name", SSNV509)
def test_multipliers_near_the_floor_of_their_space(name):
    """The computed multipliers are within 4 times the L2-best approximation of the
    exact ones in the same space (bench/multiplier_limit.py prints the table): the
    errors left are those of the space, not of the solver."""
    from xfemcontact.case import load_case
    from xfemcontact.model import Model
    from xfemcontact.post.projection import best_errors

    case = load_case(CASES / f"{name}.toml")
    model = Model(case)
    assert model.solve() > 0
    v = model.interface_values()
    c, f1 = exact(v["x"], v["y"])
    best = best_errors(model, case.reference["LAGS_C"], case.reference["LAGS_F1"])
    err_c, err_f = np.abs(v["LAGS_C"] - c).max(), np.abs(v["LAGS_F1"] - f1).max()
    print(f"{name}: LAGS_C {err_c:.2e} (floor {best['LAGS_C']:.2e}), "
          f"LAGS_F1 {err_f:.2e} (floor {best['LAGS_F1']:.2e})")
    assert best["LAGS_C"] <= err_c * 1.5 and best["LAGS_F1"] <= err_f * 1.5
    assert err_c < 4.0 * best["LAGS_C"] and err_f < 4.0 * best["LAGS_F1"]


def _inclusion(tmp_path, algo="STABLE"):
    """The 20 x 20 QUAD8 inclusion (R = 2.3 m) of bench/inclusion_family.py."""
    return inclusion_case(tmp_path, algo=algo)


def test_stable_space_is_stars_of_crossed_edges(tmp_path):
    """algo_lagr = "STABLE": the two ends of every crossed edge share a dof or belong to two
    stars, each star a vertex and neighbours across the interface (its crossed edges); fewer
    dofs than AUTO's on the same interface."""
    from xfemcontact.case import load_case
    from xfemcontact.model import Model

    spaces = {algo: Model.from_case(load_case(_inclusion(tmp_path, algo=algo))).problem.space
              for algo in ("STABLE", "AUTO")}
    sp = spaces["STABLE"]
    assert sp.algo == "STABLE" and sp.n_ties == len(sp.tie_edges) > 0
    assert len(np.unique(sp.rep)) < len(np.unique(spaces["AUTO"].rep))
    for a, b, _ in sp.tie_edges:                    # merges, not gradient ties
        assert sp.representative(np.array([a]))[0] == sp.representative(np.array([b]))[0]
    star = {}
    for a, b, _ in sp.tie_edges:
        star.setdefault(sp.representative(np.array([a]))[0], []).append((a, b))
    for ties in star.values():                     # one centre per star: in every tie
        common = set(ties[0]).intersection(*map(set, ties[1:]))
        assert len(common) >= 1, ties


def test_stable_space_on_a_floating_inclusion(tmp_path):
    """The inclusion on 20 x 20 QUAD8, R = 2.3 m: with AUTO's rich space it takes 278 Newton
    iterations and a forced status loop (bench/results/inclusion_family.md); with STABLE it
    converges in a few, without the line search's hand-over, every condition at the dofs to
    round-off."""
    out = tmp_path / "out"
    p = run_cli(["run", _inclusion(tmp_path), "-o", out])
    r = results(out)
    assert r["converged"], p.stderr
    assert r["iterations"]["newton"] <= 12 and r["multipliers"]["cycle_guards"] == 0
    assert not r["warnings"]
    cond = r["conditions"]
    assert max(v for k, v in cond.items() if not k.endswith(("_pa", "_m"))) <= 1e-13, cond


@pytest.mark.mpi
def test_stable_space_does_not_depend_on_the_partition(tmp_path):
    """The stars are chosen from data gathered from every process, keyed by input node ids:
    2 and 3 processes give the one-process answer (LAGS_C 2.7e-11 Pa apart for pressures of
    100 - 500 Pa, measured)."""
    case = _inclusion(tmp_path)
    runs = {}
    for n in (1, 2, 3):
        out = tmp_path / f"np{n}"
        p = run_cli(["run", case, "-o", out], np=n if n > 1 else None)
        assert p.returncode in (0, 1), p.stderr          # 1: the point-gap test (weak gaps)
        runs[n] = results(out)["interface"]
    for n in (2, 3):
        for k, scale in (("LAGS_C", 100.0), ("LAGS_F1", 1.0), ("gap", 1e-3), ("slip", 1e-3)):
            d = np.abs(np.array(runs[n][k]) - np.array(runs[1][k])).max()
            assert d <= 1e-10 * scale, (n, k, d)


def test_stable_space_keeps_uniform_states_exact(tmp_path):
    """A uniform state (constant LAGS_C and LAGS_F1) lies in the star space: the straight
    slip case keeps its MAX_ERROR tests."""
    case = with_contact_keys(CASES / "validation" / "slip_straight.toml", tmp_path, algo_lagr='"STABLE"')
    _, r = run_ok(case, tmp_path / "out")
    assert r["multipliers"]["algo_lagr"] == "STABLE"
    assert all(t["ok"] for t in r["tests"]) and r["tests"]


def test_stable_space_is_two_dimensional(tmp_path):
    case = with_contact_keys(CASES / "validation" / "box_incline_slip_tetra10.toml", tmp_path,
                             algo_lagr='"STABLE"')
    p = run_cli(["run", case, "-o", tmp_path / "out"])
    assert p.returncode == 2 and "Traceback" not in p.stderr
    errors = [line for line in p.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "contact.algo_lagr: STABLE is a 2-D multiplier space" in errors[0]
    assert not (tmp_path / "out").exists()


def test_coarse_start_on_a_floating_inclusion(tmp_path):
    """The default space (AUTO) with the coarse start (the default): the sticking start of the
    inclusion breaks the law, the case is solved in the stable space first, and Newton in the
    default space goes on from there: converged in at most 25 Newton iterations in all (18
    measured), no hand-over, no forced status loop; without it (-xfc_coarse_start NONE) 278
    and a forced loop (CONTACT3_86).  Both are the same solution (8e-14 of the pressure scale
    measured): the start changes the path, not the answer."""
    case = _inclusion(tmp_path, algo=None)
    runs = {}
    for mode in ("STABLE", "NONE"):
        out = tmp_path / mode
        p = run_cli(["run", case, "-o", out, "-xfc_coarse_start", mode])
        assert p.returncode in (0, 1), p.stderr                  # 1: the point-gap test
        runs[mode] = results(out)
    r = runs["STABLE"]
    coarse = r["iterations"]["coarse_start"]
    assert coarse["used"] and coarse["converged"] and coarse["algo_lagr"] == "STABLE"
    assert r["multipliers"]["algo_lagr"] == "AUTO"
    assert r["iterations"]["newton"] <= 25 and r["multipliers"]["cycle_guards"] == 0 and not r["warnings"]
    assert r["iterations"]["newton"] == coarse["newton"] + sum(r["iterations"]["newton_per_solve"])
    old = runs["NONE"]
    assert old["iterations"]["coarse_start"] is None and old["iterations"]["newton"] > 100
    assert any("CONTACT3_86" in w for w in old["warnings"])
    a, b = r["interface"], old["interface"]
    scale = np.abs(np.array(a["LAGS_C"])).max()
    assert np.abs(np.array(a["LAGS_C"]) - np.array(b["LAGS_C"])).max() <= 1e-10 * scale
    assert np.abs(np.array(a["LAGS_F1"]) - np.array(b["LAGS_F1"])).max() <= 1e-10


@pytest.mark.mpi
def test_coarse_start_on_two_processes(tmp_path):
    """The coarse model is distributed like the case; its values go over by input node ids:
    2 processes give the one-process answer."""
    case = _inclusion(tmp_path, algo=None)
    runs = {}
    for n in (1, 2):
        out = tmp_path / f"np{n}"
        p = run_cli(["run", case, "-o", out], np=n if n > 1 else None)
        assert p.returncode in (0, 1), p.stderr
        runs[n] = results(out)
        assert runs[n]["iterations"]["coarse_start"]["used"]
    for k, scale in (("LAGS_C", 100.0), ("LAGS_F1", 1.0), ("gap", 1e-3), ("slip", 1e-3)):
        d = np.abs(np.array(runs[2]["interface"][k]) - np.array(runs[1]["interface"][k])).max()
        assert d <= 1e-10 * scale, (k, d)
