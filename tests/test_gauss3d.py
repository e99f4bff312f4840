"""code_aster's Gauss-point contact (``integration = "GAUSS"``) in 3-D.

* the point law with two tangential components (Coulomb's disc): the tangent is the
  derivative of the residual and symmetric, in both friction forms; one component gives
  the 2-D law bit for bit;
* frictionless contact: a box cut by planes under a uniform pressure gives LAGS_C = -p and
  a zero gap at every interface point; a lifted block opens;
* Coulomb friction: a uniform stress that sticks gives the exact tractions (LAGS_C, both
  tangential components), in both friction forms; above the limit with an imposed slip,
  T = mu p along the slip, |(LAGS_F1, LAGS_F2)| = 1, the slip exact;
* the frozen slip directions of the loops' last fallback; bilateral sliding (glissiere); a
  load history (slow);
* the validation cases cases/validation/box_*_gauss_*.toml from the command line;
  ``mpirun -n 2`` gives the answer of one process.

The boxes and loads are those of tests/test_contact3d.py (conditions at the dofs).
"""
import numpy as np
import pytest

from conftest import ROOT, results, run_cli, write_case
from test_contact3d import MU, P, PLANES, SYMMETRY, box, sheared
from xfemcontact.case import load_case
from xfemcontact.contact import gauss_point as claw
from xfemcontact.model import Model
from xfemcontact.output import interface_csv
from xfemcontact.xfem import integration3d

SOLIDS = ("HEXA20", "TETRA10")
GAUSS = 'integration = "GAUSS"'
LAWS = {
    "semi-multiplier": claw.PointLaw(coef_cont=100.0, coef_frot=50.0, mu=0.4, friction=True),
    "traction": claw.PointLaw(coef_cont=100.0, coef_frot=50.0, mu=0.4, friction=True,
                              unknown="traction", rho_T=80.0),
}


def solve(tmp_path, text):
    model = Model.from_case(load_case(write_case(tmp_path, text)))
    assert model.solve() > 0
    return model, model.interface_values()


def gauss(text):
    """The case text with the Gauss-point form."""
    return text.replace("[contact]\n", f"[contact]\n        {GAUSS}\n", 1)


# -- the point law: Coulomb's disc --------------------------------------------------------
def disc_states(n=400, seed=5):
    """Random points with two tangential components: in contact or not, thresholds zero
    or compressive, stick and slip."""
    rng = np.random.default_rng(seed)
    chi = rng.integers(0, 2, n)
    s = np.where(rng.random(n) < 0.2, 0.0, -rng.uniform(1.0, 10.0, n))
    g, lam = rng.normal(0, 0.01, n), rng.normal(-1.0, 1.0, n)
    ut, Lam = rng.normal(0, 0.02, (n, 2)), rng.normal(0.0, 1.5, (n, 2))
    return chi, s, g, ut, lam, Lam


@pytest.mark.parametrize("form", LAWS)
def test_disc_tangent_is_the_derivative_of_the_residual(form):
    """Every tangent block matches central differences of the residual (away from the
    disc's boundary), per component; the blocks tt, LL are symmetric and tL is (d rL/dut)^T."""
    law = LAWS[form]
    chi, s, g, ut, lam, Lam = disc_states()
    t = claw.point_terms(law, chi, s, g, ut, lam, Lam)
    h = 1e-7

    def d(key, var, c):
        args = dict(g=g, ut=ut, lam=lam, Lam=Lam)
        plus, minus = dict(args), dict(args)
        e = np.zeros(2)
        e[c] = h
        plus[var], minus[var] = args[var] + e, args[var] - e
        return (claw.point_terms(law, chi, s, **plus)[key] - claw.point_terms(law, chi, s, **minus)[key]) / (2 * h)

    trial = (Lam - law.coef_frot * ut[:, :]) if form == "semi-multiplier" else (Lam + law.rho_T * ut)
    bound = 1.0 if form == "semi-multiplier" else np.abs(law.mu * s)
    smooth = np.abs(np.linalg.norm(trial, axis=1) - bound) > 1e-3 * np.maximum(bound, 1.0)
    for c in range(2):
        assert np.allclose(d("rt", "ut", c)[smooth], t["tt"][smooth][:, :, c], rtol=1e-6, atol=1e-6)
        assert np.allclose(d("rt", "Lam", c)[smooth], t["tL"][smooth][:, :, c], rtol=1e-6, atol=1e-6)
        assert np.allclose(d("rL", "ut", c)[smooth], t["tL"][smooth][:, c, :], rtol=1e-6, atol=1e-6)
        assert np.allclose(d("rL", "Lam", c)[smooth], t["LL"][smooth][:, :, c], rtol=1e-6, atol=1e-6)
    for key in ("tt", "tL", "LL"):
        assert np.allclose(t[key], t[key].transpose(0, 2, 1))
    assert t["slip"].any() and (~t["slip"] & (chi == 1) & (s != 0)).any()


@pytest.mark.parametrize("form", LAWS)
def test_disc_slip_is_on_the_boundary_along_the_trial_value(form):
    """A slipping point's projected value has the disc's radius and the trial value's
    direction; its derivative is 0 along it and bound / |q| across."""
    law = LAWS[form]
    chi, s, g, ut, lam, Lam = disc_states()
    t = claw.point_terms(law, chi, s, g, ut, lam, Lam)
    slip = t["slip"]
    musig = law.mu * s[slip]
    p = t["rt"][slip] / musig[:, None] if form == "semi-multiplier" else t["rt"][slip]
    radius = 1.0 if form == "semi-multiplier" else np.abs(musig)
    assert np.allclose(np.linalg.norm(p, axis=1), radius)
    trial = (Lam - law.coef_frot * ut) if form == "semi-multiplier" else (Lam + law.rho_T * ut)
    q = trial[slip]
    assert np.allclose(np.einsum("ki,ki->k", p, q), radius * np.linalg.norm(q, axis=1))
    A = claw.projection_derivative(q, np.broadcast_to(radius, len(q)), np.zeros(len(q), bool),
                                   np.ones(len(q), bool))
    unit = q / np.linalg.norm(q, axis=1)[:, None]
    across = np.c_[-unit[:, 1], unit[:, 0]]
    assert np.allclose(np.einsum("kij,kj->ki", A, unit), 0.0)
    assert np.allclose(np.einsum("kij,kj->ki", A, across), (radius / np.linalg.norm(q, axis=1))[:, None] * across)


@pytest.mark.parametrize("form", LAWS)
def test_one_component_is_the_2d_law_bit_for_bit(form):
    """The components' form with nf = 1 gives the scalar (2-D) terms exactly, held
    statuses included."""
    from test_law import states

    law = LAWS[form]
    chi, s, g, ut, lam, Lam = states()
    held = np.where(np.arange(len(s)) % 3 == 0, np.nan, np.where(np.arange(len(s)) % 3 == 1, 0.0, 1.0))
    for h in (None, held):
        one = claw.point_terms(law, chi, s, g, ut, lam, Lam, h)
        comp = claw.disc_terms(law, chi, s, g, ut[:, None], lam, Lam[:, None], None if h is None else h[:, None])
        for key in ("rg", "rl", "gg", "gl", "ll", "slip"):
            assert np.array_equal(one[key], comp[key])
        for key in ("rt", "rL"):
            assert np.array_equal(one[key], comp[key][:, 0])
        for key in ("tt", "tL", "LL"):
            assert np.array_equal(one[key], comp[key][:, 0, 0])


# -- frictionless contact ------------------------------------------------------------------
@pytest.mark.parametrize("cell", SOLIDS)
@pytest.mark.parametrize("plane", ["generic", "inclined", "vertices", "tilted"])
def test_uniform_pressure_is_exact(tmp_path, cell, plane):
    """-p I in both blocks: LAGS_C = -p and zero gap and slip at every interface point,
    every point in contact, one Newton iteration (a plane 0.02 h from a row of vertices,
    "near vertices", is conditioned worse: 4.4e-10 on TETRA10, 2.4e-10 at the dofs)."""
    loads = SYMMETRY + f"""
        [[traction]]
        group = ["right", "back", "top"]
        PRES = {P}
        """
    model, v = solve(tmp_path, box(cell, PLANES[plane], loads, f'frottement = "SANS"\n        {GAUSS}'))
    assert model.problem.law is not None                    # the Gauss-point problem
    assert len(v["LAGS_C"]) and v["contact"].min() == 1
    assert np.abs(v["LAGS_C"] + P).max() <= 1e-12 * P          # measured 3e-15 - 9e-14
    assert np.abs(v["gap"]).max() <= 1e-15 and v["slip"].max() <= 1e-15
    assert v["LAGS_F1"].max() == v["LAGS_F2"].max() == v["T"].max() == 0.0
    assert model.solver.iterations()["newton"] == 1


@pytest.mark.parametrize("cell", SOLIDS)
def test_opening(tmp_path, cell):
    """The top lifted by d across a tilted plane: LAGS_C = 0, the gap is d n_z, no point
    in contact."""
    d = 1e-4
    loads = SYMMETRY + f"""
        [[dirichlet]]
        group = "top"
        DZ = {d}
        """
    _, v = solve(tmp_path, box(cell, PLANES["tilted"], loads, f'frottement = "SANS"\n        {GAUSS}'))
    assert np.abs(v["LAGS_C"]).max() <= 1e-10
    assert np.abs(v["gap"] - d / np.sqrt(1.05)).max() <= 1e-12 * d
    assert v["contact"].max() == 0


# -- Coulomb friction -------------------------------------------------------------------------
TILTED = ("z - 0.45 - 0.1*x + 0.05*y", (-0.1, 0.05, 1))


def check_uniform_stress(v, n, d, tau, slip, tol):
    """The exact fields of :func:`test_contact3d.sheared` at the interface points."""
    B = integration3d.tangent_basis(n, integration3d.interface_axis(n[None, None], np.ones((1, 1))))
    expected = (tau * d) @ B / (MU * -P)
    assert np.abs(v["LAGS_C"] + P).max() <= tol * P
    assert np.abs(v["T"] - tau).max() <= tol * P
    assert np.abs(v["LAGS_F1"] - expected[0]).max() <= tol and np.abs(v["LAGS_F2"] - expected[1]).max() <= tol
    assert np.abs(v["gap"]).max() <= 1e-13
    assert np.abs(v["slip"] - slip).max() <= 1e-9 * max(slip, 1e-6)
    assert (v["sliding"] == (slip > 0)).all() and (v["contact"] == 1).all()
    if slip > 0:
        s1 = np.c_[v["slip1"], v["slip2"]] @ B.T            # the slip vector
        assert np.abs(s1 - slip * d).max() <= 1e-12
        assert np.abs(np.hypot(v["LAGS_F1"], v["LAGS_F2"]) - 1.0).max() <= tol


@pytest.mark.parametrize("cell", SOLIDS)
@pytest.mark.parametrize("unknown", ["LAGS_F1", "TRACTION"])
def test_stick_is_exact(tmp_path, cell, unknown):
    """|tau| = 40 Pa < mu p = 50 Pa across the tilted plane: LAGS_C, T, LAGS_F1, LAGS_F2
    exact, no slip, in both friction forms."""
    text, n, d = sheared(cell, TILTED[0], TILTED[1], 40.0, 0.0)
    text = gauss(text).replace("[contact]\n", f'[contact]\n        friction_unknown = "{unknown}"\n', 1)
    model, v = solve(tmp_path, text)
    assert model.problem.friction_unknown == ("traction" if unknown == "TRACTION" else "semi-multiplier")
    check_uniform_stress(v, n, d, 40.0, 0.0, 1e-10)


@pytest.mark.parametrize("cell", SOLIDS)
@pytest.mark.parametrize("plane", ["generic", "tilted"])
def test_slip_is_exact(tmp_path, cell, plane):
    """tau = mu p with the top moved by 5e-4 m along d: T = mu p along the slip, the slip
    exact, every point sliding, |(LAGS_F1, LAGS_F2)| = 1; LAGS_C to the threshold loop's
    RESI_FROT (1e-10: measured 1e-9 relative at most), in at most 40 Newton iterations
    (measured 17 - 29; the conditions at the dofs take 9 - 12)."""
    level_set, grad = {"generic": ("z - 0.45", (0, 0, 1)), "tilted": TILTED}[plane]
    text, n, d = sheared(cell, level_set, grad, MU * P, 5e-4)
    model, v = solve(tmp_path, gauss(text))
    check_uniform_stress(v, n, d, MU * P, 5e-4, 1e-8)
    assert model.solver.iterations()["newton"] <= 40


def test_slip_traction_form(tmp_path):
    """The traction as friction unknown (its trial value projected on the disc of radius
    mu |s|), TETRA10, tilted plane, slipping: the exact state, LAGS_F1 and LAGS_F2 (the
    traction over mu LAGS_C, the threshold of the last threshold iteration against LAGS_C
    now) to 1e-7 (measured 6e-8)."""
    text, n, d = sheared("TETRA10", TILTED[0], TILTED[1], MU * P, 5e-4)
    text = gauss(text).replace("[contact]\n", '[contact]\n        friction_unknown = "TRACTION"\n', 1)
    model, v = solve(tmp_path, text)
    assert model.problem.friction_unknown == "traction"
    check_uniform_stress(v, n, d, MU * P, 5e-4, 1e-7)


def test_frozen_slip_directions(tmp_path):
    """The loops' last fallback in 3-D: the statuses are the unit slip directions (rounded),
    and Newton with them held (a linear problem) keeps the converged slipping state."""
    text, n, d = sheared("TETRA10", TILTED[0], TILTED[1], MU * P, 5e-4)
    model, v = solve(tmp_path, gauss(text))
    problem = model.problem
    status = problem.friction_statuses(model.x)
    k, ng = problem.points.w.shape
    assert status.shape == (k, ng, 2)
    live = problem.points.w != 0
    assert np.allclose(np.linalg.norm(status[live], axis=1), 1.0, atol=1e-7)
    x0 = model.x.copy()
    with problem.holding(status):
        model.solver.newton.solve(None, model.x)
    assert model.solver.newton.getConvergedReason() > 0
    assert (model.x - x0).norm() <= 1e-6 * x0.norm()
    with problem.holding(np.where(live, 0.0, np.nan)):           # the stick predictor's form
        assert np.array_equal(problem._state.held[..., 0], problem._state.held[..., 1], equal_nan=True)


def test_glissiere(tmp_path):
    """law = "glissiere" with the Gauss-point form (SSNV201 A-like, HEXA20): every test of
    the case OK (open, closed, kept closed in tension, sliding)."""
    text = (ROOT / "cases" / "validation" / "ssnv201a_like_hexa20.toml").read_text()
    case = write_case(tmp_path, text.replace("[contact]\n", f"[contact]\n{GAUSS}\n", 1), "g.toml")
    done = run_cli(["run", case, "-o", tmp_path / "out", "-q"])
    assert done.returncode == 0, done.stdout + done.stderr
    r = results(tmp_path / "out")
    assert r["tests"] and all(t["ok"] for t in r["tests"])


@pytest.mark.slow
def test_load_history(tmp_path):
    """A 3-D load history with the Gauss-point form (cases/validation/history_turn3d_hexa20.toml:
    stick, slip along x, then y, then the diagonal, unloading; about 12 s): every test OK,
    the step's tangential jump counted from the previous step's in two components."""
    text = (ROOT / "cases" / "validation" / "history_turn3d_hexa20.toml").read_text()
    case = write_case(tmp_path, text.replace("[contact]\n", f"[contact]\n{GAUSS}\n", 1), "turn.toml")
    done = run_cli(["run", case, "-o", tmp_path / "out", "-q"])
    assert done.returncode == 0, done.stdout + done.stderr
    r = results(tmp_path / "out")
    assert len(r["tests"]) > 10 and all(t["ok"] for t in r["tests"])


# -- command line, processes --------------------------------------------------------------------
VALIDATION = ("box_plane_contact_gauss_hexa20", "box_plane_opening_gauss_tetra10", "box_incline_stick_gauss_hexa20",
              "box_incline_slip_gauss_tetra10")


@pytest.mark.parametrize("name", VALIDATION)
def test_validation_cases(run_once, name):
    """The 3-D validation cases with the Gauss-point form: every test OK, the 3-D columns of
    interface.csv, the Gauss-point problem's statuses at every point."""
    done, out = run_once(ROOT / "cases" / "validation" / f"{name}.toml", "-q")      # shared (conftest.Runs)
    assert done.returncode == 0, done.stdout + done.stderr
    r = results(out)
    assert r["tests"] and all(t["ok"] for t in r["tests"])
    table = interface_csv.read(out / "interface.csv")
    assert set(interface_csv.COLUMNS_3D) <= set(table) and len(table["x"]) == len(r["interface"]["x"]) > 0
    assert (table["contact"] == (0 if "opening" in name else 1)).all()
    assert (table["sliding"] == (1 if "slip" in name else 0)).all()


def test_two_processes_give_the_answer_of_one(run_once):
    """``mpirun -n 2`` reproduces one process's interface.csv to 1e-10 on the slip case
    (TETRA10, tilted plane; the gap, zero, to 1e-10 of the displacements; measured 2.7e-13),
    in as many Newton iterations."""
    case = ROOT / "cases" / "validation" / "box_incline_slip_gauss_tetra10.toml"
    outs, newton = {}, {}
    for np_ in (None, 2):                  # one process: the run of test_validation_cases
        done, out = run_once(case, "-q", np_=np_)
        assert done.returncode == 0, done.stdout + done.stderr
        outs[np_ or 1] = interface_csv.read(out / "interface.csv")
        newton[np_ or 1] = results(out)["iterations"]["newton"]
    one, two = outs[1], outs[2]
    assert np.array_equal(one["cell"], two["cell"]) and (one["sliding"] == 1).all()
    for key in ("x", "y", "z", "LAGS_C", "LAGS_F1", "LAGS_F2", "T", "gap", "slip"):
        scale = max(np.abs(one[key]).max(), 1e-4 if key in ("gap", "slip") else 1e-300)
        assert np.abs(one[key] - two[key]).max() <= 1e-10 * scale, key
    assert newton[1] == newton[2]
