"""Coulomb's law in Newton (integration = "NOEUD", -xfc_friction_newton COULOMB, the default).

The friction bound of a slipping dof is -mu LAGS_C of the iterate, contact and friction
statuses are updated at every Newton iteration: a semi-smooth Newton on the whole law.
Its tangent has a non-symmetric part (the slipping traction's dependence on the
pressure), factorised by LU on an AIJ copy while something slips, and applied beside
the LDL^T factors of the symmetric part when the user chooses a Krylov method.
"""
import csv
import importlib.util
import sys

import numpy as np
import pytest

from conftest import CASES, MESHES, ROOT, inclusion_case, results, run_cli
from xfemcontact._petsc import PETSc

SLIP = CASES / "validation" / "slip_straight.toml"
SLIP_3D = CASES / "validation" / "box_incline_slip_tetra10.toml"

spec = importlib.util.spec_from_file_location("campaign", ROOT / "bench" / "campaign.py")
campaign = importlib.util.module_from_spec(spec)
sys.modules.setdefault("campaign", campaign)
spec.loader.exec_module(campaign)


def interface(out):
    with open(out / "interface.csv") as f:
        rows = list(csv.DictReader(f))
    keys = ("x", "y", "LAGS_C", "LAGS_F1", "gap", "slip")
    return {k: np.array([float(r[k]) for r in rows]) for k in keys}


def run_ok(args, out, np_=None):
    p = run_cli(["run", *args, "-o", out], np=np_)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    return results(out)


def shared_ok(run_once, case, *options):
    """``run_ok`` of a one-process run several tests read, done once (conftest.Runs):
    results.json and the output folder."""
    p, out = run_once(case, *options)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    return results(out), out


def central_difference(model, x, d, eps):
    """(R(x + eps d) - R(x - eps d)) / (2 eps), the residual's derivative along ``d``."""
    f1, f2 = x.duplicate(), x.duplicate()
    xp, xm = x.copy(), x.copy()
    xp.axpy(eps, d)
    xm.axpy(-eps, d)
    model.residual(None, xp, f1)
    model.residual(None, xm, f2)
    return (f1.getArray() - f2.getArray()) / (2 * eps)



def tangent_at_solution(model, seed):
    """At the solved state ``x`` of ``model``: a random direction ``d`` of every interface
    dof (the jump dofs on the scale of the displacements, the multipliers on that of the
    tractions), the tangent assembled in ``model.K`` and the coupling ``C`` (checked to lie
    in the interface elements' blocks, no entry on padding): ``(x, d, C)``."""
    problem, x = model.problem, model.x
    nh, m, g = problem._nh, problem._m, problem.indices
    lo, hi = x.getOwnershipRange()
    values = x.getArray(readonly=True)
    rng = np.random.default_rng(seed)
    d = x.duplicate()
    d.set(0.0)
    for block in (g[:, :nh], g[:, nh:nh + m][problem.slot], g[:, nh + m:][problem.fslot]):
        dofs = np.unique(block[block >= 0])
        dofs = dofs[(dofs >= lo) & (dofs < hi)]
        d.setValues(dofs, rng.standard_normal(len(dofs)) * np.abs(values[dofs - lo]).max())
    d.assemble()
    model.residual(None, x, x.duplicate())
    model.jacobian(None, x, model.K, model.K)
    C = problem.coupling()
    assert C is not None
    live = g >= 0
    assert not np.any(C[~(live[:, :, None] & live[:, None, :])])
    return x, d, C


def test_coupling_is_the_derivative_of_the_residual():
    """At a sliding state the Jacobian (assembled symmetric part plus the coupling) is the
    derivative of the residual: central differences agree to 1e-6 relative."""
    from xfemcontact.case import load_case
    from xfemcontact.model import Model

    model = Model.from_case(load_case(SLIP))
    assert model.solve() > 0
    problem = model.problem
    x = model.x.copy()
    # a direction of the pressures (LAGS_C dofs), where the coupling acts
    rng = np.random.default_rng(3)
    d = x.duplicate()
    d.set(0.0)
    nh, m = problem._nh, problem._m
    lam_dofs = np.unique(problem.indices[:, nh:nh + m][problem.slot])
    lo, hi = d.getOwnershipRange()
    lam_dofs = lam_dofs[(lam_dofs >= lo) & (lam_dofs < hi)]
    d.setValues(lam_dofs, rng.standard_normal(len(lam_dofs)) * 100.0)
    d.assemble()
    f0 = x.duplicate()
    model.residual(None, x, f0)                       # the statuses at x, then commit them
    model.jacobian(None, x, model.K, model.K)
    C = problem.coupling()
    assert C is not None and np.abs(C).max() > 0      # something slips with its bound in Newton
    Jd = x.duplicate()
    model.K.mult(d, Jd)
    problem.add_product(C, d, Jd)
    fd = central_difference(model, x, d, 1e-7 * x.norm() / d.norm())
    jd = Jd.getArray()
    assert np.abs(fd - jd).max() <= 1e-6 * np.abs(jd).max()
    # without the coupling the rows of the slipping dofs (D (T - f) / rho_T: the equilibrium
    # holds T itself) miss the derivative of their bound, of the order of the coupling itself
    Kd = x.duplicate()
    model.K.mult(d, Kd)
    rows = np.unique(problem.indices[:, nh + m:][problem.fslot])
    rows = rows[(rows >= lo) & (rows < hi)] - lo
    assert np.abs(fd - Kd.getArray())[rows].max() > 0.5 * np.abs(jd[rows]).max()


def test_augmented_coupling_is_the_derivative_of_the_residual():
    """2-D with the line search (the default): a slipping dof's bound is -mu (LAGS_C + r gn),
    Alart and Curnier's augmented pressure, so its traction depends on the jump dofs too, and
    the equilibrium holds the dof's own T.  At the sliding state the Jacobian (symmetric part
    plus coupling) is the derivative of the residual in a random direction of every interface
    dof (jumps, LAGS_C, LAGS_F1): central differences agree to 1e-6 relative, and the coupling
    stays in the interface elements' blocks."""
    from xfemcontact.case import load_case
    from xfemcontact.model import Model

    model = Model.from_case(load_case(SLIP))
    assert model.solve() > 0
    problem = model.problem
    assert problem.merit_active and problem.guards == 0
    x, d, C = tangent_at_solution(model, seed=7)
    nh, m, g = problem._nh, problem._m, problem.indices
    lo, hi = x.getOwnershipRange()
    assert np.abs(C[:, nh + m:, :nh]).max() > 0              # the bound's dependence on the gaps
    Jd = x.duplicate()
    model.K.mult(d, Jd)
    problem.add_product(C, d, Jd)
    fd = central_difference(model, x, d, 1e-6)
    jd = Jd.getArray()
    assert np.abs(fd - jd).max() <= 1e-6 * np.abs(jd).max()
    Kd = x.duplicate()
    model.K.mult(d, Kd)
    rows = np.unique(g[:, nh + m:][problem.fslot])
    rows = rows[(rows >= lo) & (rows < hi)] - lo
    assert np.abs(fd - Kd.getArray())[rows].max() > 0.5 * np.abs(jd[rows]).max()


def test_augmented_bound_and_kink():
    """The complementarity functions bound friction by the augmented pressure: a dof that
    closes with lam = 0 (gn < 0) already has friction; at a solution (gn = 0 where in contact)
    the bound is -mu lam and both functions vanish.  A slipping dof that has not slipped in the
    step (gt = 0, |T| = b: the start of a load step) takes the stick branch, one that has keeps
    its slip, and a trial traction beyond the bound the other way reverses it."""
    from xfemcontact.contact import nodal

    mu, r = 0.5, 1e6
    lam, gn = np.array([0.0, -100.0, 0.0]), np.array([-1e-6, 0.0, 1e-6])
    cn, ct = nodal.complementarity(lam, np.zeros(3), gn, np.array([1e-5, 0.0, 0.0]), mu, r)
    assert cn == pytest.approx([1.0, 0.0, 0.0])                # r |gn| = 1 Pa of interpenetration
    assert ct == pytest.approx([-0.5, 0.0, 0.0])               # the bound mu r |gn| = 0.5 Pa
    cn, ct = nodal.complementarity(np.array([-100.0]), np.array([50.0]), np.array([0.0]),
                                   np.array([2e-6]), mu, r)
    assert cn[0] == 0.0 and ct[0] == 0.0                       # slipping at the bound mu |lam|
    slip, active, b = np.ones(3), np.ones(3, bool), np.full(3, 50.0)
    T, gt = np.array([50.0, 50.0, 50.0]), np.array([0.0, 1e-6, -2e-4])
    new = nodal.friction_status_augmented(slip, active, T, gt, b, r, tol_slip=1e-12)
    assert list(new) == [0.0, 1.0, -1.0]


@pytest.fixture
def coulomb_newton():
    """-xfc_friction_newton COULOMB in the options database for an in-process model."""
    opts = PETSc.Options()
    opts.setValue("xfc_friction_newton", "COULOMB")
    yield
    opts.delValue("xfc_friction_newton")


def test_coupling_is_the_derivative_of_the_residual_in_3d(coulomb_newton):
    """3-D (two friction components): a slipping dof's traction -mu LAGS_C q / |q|, q = T + r gt,
    depends on its pressure, its traction and the jump dofs (through its mean slip).  At the
    sliding state of box_incline_slip_tetra10 the Jacobian (symmetric part plus coupling) is
    the derivative of the residual in a random direction of every interface dof (jumps,
    LAGS_C, LAGS_F1, LAGS_F2): central differences agree to 1e-6 relative; the coupling lies
    in the interface elements' blocks (the AIJ copy keeps its pattern, no entry on padding)."""
    from xfemcontact.case import load_case
    from xfemcontact.model import Model

    model = Model.from_case(load_case(SLIP_3D))
    assert model.solve() > 0
    problem = model.problem
    assert problem.guards == 0                        # the state of Coulomb's law in Newton
    x, d, C = tangent_at_solution(model, seed=5)
    A = PETSc.Mat()
    model.K.convert("aij", A)
    entries = A.getInfo()["nz_used"]
    A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
    problem.add_matrices(A, C)
    A.assemble()
    assert A.getInfo()["nz_used"] == entries
    Jd = x.duplicate()
    A.mult(d, Jd)
    fd = central_difference(model, x, d, 1e-6)
    jd = Jd.getArray()
    assert np.abs(fd - jd).max() <= 1e-6 * np.abs(jd).max()
    Kd = x.duplicate()
    model.K.mult(d, Kd)
    assert np.abs(fd - Kd.getArray()).max() > 1e-3 * np.abs(jd).max()


def test_both_newtons_give_the_same_answer(tmp_path, run_once):
    """-xfc_friction_newton COULOMB (the default) and TRESCA (the threshold fixed point) end
    on the same discrete solution, the former in fewer Newton iterations; the coupled
    Jacobians are counted, factorised by LU."""
    r1, c = shared_ok(run_once, SLIP)
    r2 = run_ok([SLIP, "-xfc_friction_newton", "TRESCA"], tmp_path / "t")
    a, b = interface(c), interface(tmp_path / "t")
    for f, scale in (("LAGS_C", 100.0), ("LAGS_F1", 1.0), ("gap", 1e-3), ("slip", 1e-3)):
        assert np.abs(a[f] - b[f]).max() <= 1e-8 * scale, f
    assert r1["multipliers"]["friction_newton"] == "COULOMB"
    assert r2["multipliers"]["friction_newton"] == "TRESCA"
    assert r1["iterations"]["newton"] < r2["iterations"]["newton"]
    assert r1["linear_solver"]["coupled_jacobians"] > 0
    assert r2["linear_solver"]["coupled_jacobians"] == 0


def test_line_search_where_it_does_not_apply(tmp_path):
    """-xfc_friction_line_search MERIT on a 3-D case (it is written for 2-D): the run says it
    is ignored, and solves as without it."""
    r = run_ok([SLIP_3D, "-q", "-xfc_friction_line_search", "MERIT"], tmp_path / "m")
    assert any("MERIT" in w and "ignored here (3-D)" in w for w in r["warnings"]), r["warnings"]
    assert r["iterations"]["damped_steps"] == 0


def test_conditions_at_the_dofs(tmp_path, run_once):
    """results.json ``conditions``: every condition of the law holds at the dofs of the
    converged slip to round-off; a threshold loop stopped at 1e-2 (-friction_snes_rtol)
    leaves thresholds that are not the pressures, and the report says by how much."""
    r, _ = shared_ok(run_once, SLIP)
    cond = r["conditions"]
    assert cond["pressure_scale_pa"] == pytest.approx(100.0) and cond["jump_scale_m"] == pytest.approx(8e-4)
    measures = ("tension", "interpenetration", "contact_complementarity", "friction_excess",
                "friction_complementarity", "slip_direction", "threshold")
    assert max(cond[k] for k in measures) <= 1e-13, cond
    run_cli(["run", SLIP, "-o", tmp_path / "loose", "-q", "-xfc_friction_newton", "TRESCA", "-friction_snes_rtol", "1e-2"])
    loose = results(tmp_path / "loose")["conditions"]
    assert 1e-4 < loose["threshold"] < 1e-1, loose
    ok, _ = shared_ok(run_once, CASES / "ssnv509a.toml")          # sticks: jumps of round-off
    assert max(ok["conditions"][k] for k in measures) <= 1e-13, ok["conditions"]


def test_conditions_warning():
    """The warning of a converged solve reads every condition but ``threshold`` (RESI_FROT's),
    and only above CONDITIONS_WARN; None entries (glissiere, no friction) are skipped."""
    from xfemcontact.contact.problem import CONDITIONS_WARN, conditions_warning

    ok = dict(pressure_scale_pa=100.0, jump_scale_m=1e-3, tension=1e-14, interpenetration=0.0,
              contact_complementarity=3e-15, friction_excess=None, friction_complementarity=None,
              slip_direction=None, threshold=5e-3)
    assert conditions_warning(ok) is None and conditions_warning(None) is None
    assert conditions_warning(dict(ok, tension=CONDITIONS_WARN)) is None
    note = conditions_warning(dict(ok, interpenetration=2e-6, friction_excess=1e-7))
    assert note is not None and "2.0e-06" in note and "(interpenetration;" in note


def test_positive_lumped_weights(tmp_path):
    """A dependent vertex whose extrapolation gives a dof a lumped weight D_a <= 0 takes its
    convex combination for good (nodal_problem._positive_weights): the floating inclusion of
    bench/inclusion_family.py on 24 x 24 TRIA6 with R = 2.1 m had D = -3.7e-3 and -1.4e-3
    (median 0.26), and its status loop cycled between a dof in tension and the same dof
    interpenetrating: 243 Newton iterations, 7 forced loops and a dof in tension at 0.46 of
    the pressure scale.  Now every D_a > 0, no forced loop, every condition to round-off."""
    from xfemcontact.case.load import load_case
    from xfemcontact.model import Model

    case = inclusion_case(tmp_path, "TRIA6", 24, 2.1)
    model = Model.from_case(load_case(case))
    problem = model.problem
    assert problem.held_convex.sum() > 0
    assert (problem._D[problem.slot] > 0).all()
    p = run_cli(["run", case, "-o", tmp_path / "out"])
    r = results(tmp_path / "out")
    assert p.returncode in (0, 1), p.stderr[-2000:]       # 1: the case's point-gap test
    assert r["converged"] and not any("CONTACT3_86" in w for w in r["warnings"]), r["warnings"]
    assert r["iterations"]["newton"] <= 25
    assert r["multipliers"]["convex_for_weight"] == problem.held_convex.sum()
    cond = {k: v for k, v in r["conditions"].items() if k not in ("pressure_scale_pa", "jump_scale_m") and v is not None}
    assert max(cond.values()) <= 1e-12, cond
    # the vertices are chosen from data of every process: two processes give the same answer
    p2 = run_cli(["run", case, "-o", tmp_path / "np2", "--no-plots"], np=2)
    assert p2.returncode in (0, 1), p2.stderr[-2000:]
    assert results(tmp_path / "np2")["multipliers"]["convex_for_weight"] == problem.held_convex.sum()
    a, b = interface(tmp_path / "out"), interface(tmp_path / "np2")
    assert np.abs(a["LAGS_C"] - b["LAGS_C"]).max() <= 1e-10 * 100.0
    assert np.abs(a["gap"] - b["gap"]).max() <= 1e-10 * 1e-3


def test_positive_lumped_weights_of_gradient_ties(tmp_path):
    """A gradient tie that gives a dof D_a <= 0 is kept while nothing but sticking is asked
    (its merge would cost linear fields their exactness: cases/validation/flat_arc.toml) and
    merged once statuses are in play: the inclusion on 40 x 40 QUAD8 with R = 2.45 m (D_a =
    -3.4e-2 for a median of 0.15) took 486 Newton iterations and 4 forced status loops; now
    within 25, none forced, every condition to round-off."""
    from xfemcontact.case.load import load_case
    from xfemcontact.model import Model

    case = inclusion_case(tmp_path, "QUAD8", 40, 2.45)
    problem = Model.from_case(load_case(case)).problem
    assert problem.held_convex.sum() == 0 and (problem._D[problem.slot] <= 0).any()
    p = run_cli(["run", case, "-o", tmp_path / "out", "--no-plots"])
    assert p.returncode in (0, 1), p.stderr[-2000:]       # 1: the case's point-gap test
    r = results(tmp_path / "out")
    assert r["converged"] and not any("CONTACT3_86" in w for w in r["warnings"]), r["warnings"]
    assert r["iterations"]["newton"] <= 25 and r["multipliers"]["convex_for_weight"] > 0
    cond = {k: v for k, v in r["conditions"].items() if k not in ("pressure_scale_pa", "jump_scale_m") and v is not None}
    assert max(cond.values()) <= 1e-12, cond


def test_an_answer_that_breaks_the_law_is_flagged(tmp_path):
    """A converged state whose conditions at the dofs do not hold (here: one dof in contact
    pulled to a tension of the pressure's order) gets the warning of check_conditions."""
    from xfemcontact.case.load import load_case
    from xfemcontact.model import Model

    model = Model.from_case(load_case(SLIP))
    assert model.solve() > 0 and not [w for w in model.run_warnings() if "holds at the" in w]
    problem = model.problem
    lam_dofs = model.layout.lag_global[:, 0]
    lo, hi = model.x.getOwnershipRange()
    scale = problem.conditions(model.x)["pressure_scale_pa"]
    a = lam_dofs[(lam_dofs >= max(lo, 0)) & (lam_dofs < hi)][0]
    model.x.setValue(int(a), 0.5 * scale)
    model.x.assemble()
    problem.check_conditions(model.x)
    flagged = [w for w in model.run_warnings() if "holds at the multiplier dofs only to" in w]
    assert len(flagged) == 1 and "(tension;" in flagged[0], flagged


def test_sticking_keeps_one_symmetric_factorisation(run_once):
    """SSNV509 a sticks everywhere: nothing couples, one Newton iteration, one Cholesky
    factorisation of the symmetric (SBAIJ) matrix; its sticking start satisfies the law, so
    no coarse start either."""
    r, _ = shared_ok(run_once, CASES / "ssnv509a.toml")
    ls = r["linear_solver"]
    assert (ls["pc"], ls["matrix"], ls["jacobians"], ls["coupled_jacobians"]) == ("cholesky", "seqsbaij", 1, 0)
    assert r["iterations"]["newton"] == 1 and r["iterations"]["coarse_start"] is None


def test_user_krylov_method_on_the_coupled_tangent(tmp_path, run_once):
    """-ksp_type gmres: the coupling is applied beside the factors of the symmetric part;
    the same answer."""
    _, lu = shared_ok(run_once, SLIP)
    run_ok([SLIP, "-ksp_type", "gmres", "-ksp_rtol", "1e-12", "-ksp_pc_side", "right"], tmp_path / "k")
    a, b = interface(lu), interface(tmp_path / "k")
    assert np.abs(a["LAGS_C"] - b["LAGS_C"]).max() <= 1e-8 * 100.0
    assert np.abs(a["slip"] - b["slip"]).max() <= 1e-8 * 1e-3


def test_bad_friction_newton_option(tmp_path):
    p = run_cli(["run", SLIP, "-o", tmp_path / "o", "-xfc_friction_newton", "FAST"])
    assert p.returncode == 2
    assert "-xfc_friction_newton FAST: unknown value (expected one of COULOMB, TRESCA)" in p.stderr


@pytest.mark.parametrize("line_search, newton, guards", [("NONE", 21, 1), ("MERIT", 7, 0)])
def test_cycle_guard(tmp_path, line_search, newton, guards):
    """At the Coulomb limit on unstructured quadrangles (dofs with tiny lumped weights
    at the ends of the interface) the active sets of the semi-smooth Newton with full steps
    and the bound mu |LAGS_C| cycle (NONE): the guard hands the step to the threshold loop,
    Coulomb's law goes back into Newton once that loop has settled
    (nodal_problem.REARM_CHANGE), and the run ends exact.  With the line search and the
    augmented bound (MERIT, the default) the end dof that closes with a pressure of zero
    finds its status at once: no guard."""
    c = {r.name: r for r in campaign.TABLE}["limit-D_q8u3x2_a+20_gen_nu0"]
    path = tmp_path / "case.toml"
    path.write_text(campaign.case_text(c, meshes=str(MESHES)))
    r = run_ok([path, "-xfc_friction_line_search", line_search], tmp_path / "o")
    assert all(t["ok"] for t in r["tests"]), r["tests"]
    assert (r["multipliers"]["cycle_guards"] >= 1) == (guards >= 1)
    assert (r["multipliers"]["coulomb_rearms"] >= 1) == (guards >= 1)
    # measured: 25 before Coulomb's law went back into Newton after the guard, 21 with it;
    # with the line search 25 with the bound mu |LAGS_C| (the merit function stalled: the guard),
    # 7 with the augmented bound
    assert r["iterations"]["newton"] <= newton


@pytest.mark.parametrize("case, line_search, newton, damped", [
    # issue 18: the chatter of a narrow stick zone between slip zones of opposite directions
    # (34 Newton iterations with full steps and the guard, 17 of them before it; 18 with the
    # line search and the bound mu |LAGS_C|, 15 with the augmented bound)
    ("campaign/curved_arc_shear_quad8.toml", "MERIT", 15, 1),
    ("campaign/curved_arc_shear_quad8.toml", "NONE", 34, 0),
    # SSNV509 with mu = 0.3: a period-7 cycle of full steps (30 with the guard)
    ("validation/low_friction.toml", "MERIT", 14, 1),
    # an interface that closes again under shear: with the bound mu |LAGS_C| its dofs closed
    # with LAGS_C = 0, took no friction, slid a whole step and reversed (40 Newton iterations
    # over the history, 25 with full steps and the guard); the augmented bound gives them the
    # friction of their interpenetration at once
    ("validation/history_open_reclose.toml", "MERIT", 15, 0),
    ("validation/history_open_reclose.toml", "NONE", 25, 0),
])
def test_line_search(tmp_path, case, line_search, newton, damped):
    """Newton's steps damped on the merit function of the complementarity functions
    (solver/linesearch.py), the friction bound Alart and Curnier's augmented pressure: the
    semi-smooth Newton converges with Coulomb's law in it, no guard, no forced status loop;
    ``-xfc_friction_line_search NONE`` is the full-step Newton with the bound mu |LAGS_C| and
    the cycle guard."""
    # from the sticking start (-xfc_coarse_start NONE): the line search's own effect
    r = run_ok([CASES / case, "-xfc_friction_line_search", line_search, "-xfc_coarse_start", "NONE"],
               tmp_path / "o")
    assert all(t["ok"] for t in r["tests"]), r["tests"]
    assert r["iterations"]["newton"] <= newton
    assert not any("forced" in w for w in r["warnings"])
    if line_search == "MERIT":
        assert r["multipliers"]["cycle_guards"] == 0
        assert r["iterations"]["damped_steps"] >= damped


def test_default_is_the_line_search(run_once):
    """Without -xfc_friction_line_search a 2-D Coulomb case runs with the line search (the
    arc under shear: 20 Newton iterations with the coarse start, 15 from the sticking start;
    no guard), and says nothing about it."""
    r, _ = shared_ok(run_once, CASES / "campaign" / "curved_arc_shear_quad8.toml")
    assert r["iterations"]["newton"] <= 20 and r["multipliers"]["cycle_guards"] == 0
    assert r["iterations"]["merit_evaluations"] > 0
    assert not any("friction_line_search" in w for w in r["warnings"])


def test_merit_descent(tmp_path):
    """Newton's step descends the merit function: theta(x - eps y) = theta(x) (1 - 2 eps) to
    first order at every iterate of the arc under shear (the statuses of the augmented tests
    are the branches of the complementarity functions)."""
    from xfemcontact.case.load import load_case
    from xfemcontact.model import Model
    from xfemcontact.solver.nonlinear import NonlinearSolver

    ratios = []
    opts = PETSc.Options()
    opts.setValue("xfc_friction_line_search", "MERIT")
    try:
        model = Model(load_case(CASES / "campaign" / "curved_arc_shear_quad8.toml"))
        model.solver = solver = NonlinearSolver(model)
    finally:
        opts.delValue("xfc_friction_line_search")
    ls = solver.line_search
    assert ls is not None
    inner = ls.__call__

    def check(x, y):
        if ls.problem.merit_active:
            theta = ls.merit(x)
            w = x.duplicate()
            w.waxpy(-1e-7, y, x)
            ratios.append((ls.merit(w) - theta) / (-2e-7 * theta))
        return inner(x, y)

    solver.newton.setLineSearchPreCheck(check)
    assert model.solve() > 0
    assert len(ratios) >= 5
    assert np.allclose(ratios, 1.0, atol=0.05), ratios


@pytest.mark.parametrize("np_", [2, 3])
def test_coupled_tangent_in_parallel(tmp_path, run_once, np_):
    """The AIJ copy and its LU under mpirun: the one-process answer to 1e-10."""
    _, one = shared_ok(run_once, SLIP)
    run_ok([SLIP], tmp_path / "n", np_=np_)
    a, b = interface(one), interface(tmp_path / "n")
    ka = np.lexsort((a["y"].round(9), a["x"].round(9)))
    kb = np.lexsort((b["y"].round(9), b["x"].round(9)))
    for f, scale in (("LAGS_C", 100.0), ("LAGS_F1", 1.0), ("slip", 1e-3)):
        assert np.abs(a[f][ka] - b[f][kb]).max() <= 1e-10 * scale, f


@pytest.mark.mpi
def test_process_without_interface_elements(tmp_path, run_once):
    """SSNV509 a with mu = 0.2 on 3 processes: one holds no interface element, the others
    slip; the coupled tangent is assembled on every process (an empty batch once failed
    to reshape) and the answer is the one-process one."""
    case = ROOT / "cases" / "campaign" / "curved_ssnv509_mu02_quad8.toml"
    r1, one = shared_ok(run_once, case)        # shared with test_campaign's curved cases
    r3 = run_ok([case], tmp_path / "3", np_=3)
    assert min(r3["geometry"]["cut_cells_per_process"]) == 0
    assert r1["linear_solver"]["coupled_jacobians"] > 0
    a, b = interface(one), interface(tmp_path / "3")
    ka = np.lexsort((a["y"].round(9), a["x"].round(9)))
    kb = np.lexsort((b["y"].round(9), b["x"].round(9)))
    # (the guard hands this case over to the threshold loop, and Coulomb's law goes back into
    # Newton once that loop has settled: 3 processes give the one-process answer to 5e-13 of
    # the scales, bench/results/campaign_rearm.md; 3e-8 when the threshold loop, stopping at
    # RESI_FROT = 1e-6, ended the run)
    for f, scale in (("LAGS_C", 0.1), ("LAGS_F1", 1.0), ("slip", 1e-6)):
        assert np.abs(a[f][ka] - b[f][kb]).max() <= 1e-10 * scale, f


@pytest.mark.slow
@pytest.mark.parametrize("cell, mu", [("TETRA10", 0.1), ("HEXA20", 0.05)])
def test_sphere_partial_slip_after_the_guard(tmp_path, cell, mu):
    """A sphere under -p I - q e_z e_z (bench/contact3d_sphere.py, N = 6) slips: the guard
    fires, the threshold loop keeps the slip direction in Newton's tangent (a Tresca problem;
    with the direction a status its loop did not converge: exit 3 after 98 and 119 Newton
    iterations), Coulomb's law goes back into Newton, and the answer is admissible at every
    interface point: LAGS_C <= 0 and |(LAGS_F1, LAGS_F2)| <= 1."""
    sys.path.insert(0, str(ROOT / "bench"))
    try:
        from contact3d_sphere import case
    finally:
        sys.path.pop(0)
    path = tmp_path / "sphere.toml"
    path.write_text('title = "sphere, partial slip"\n' + case(cell, 6, mu))
    r = run_ok([path], tmp_path / "o")
    assert r["multipliers"]["cycle_guards"] >= 1 and r["multipliers"]["coulomb_rearms"] >= 1
    assert r["iterations"]["newton"] <= 30          # measured: 17 (TETRA10), 25 (HEXA20)
    v = {k: np.array(a, dtype=float) for k, a in r["interface"].items() if k != "end"}
    p = np.abs(v["LAGS_C"]).max()
    assert v["LAGS_C"].max() <= 1e-9 * p
    assert np.hypot(v["LAGS_F1"], v["LAGS_F2"]).max() <= 1.0 + 1e-9



def test_line_search_breaks_a_cycle():
    """A merit value met again in a solve is a cycle: the step from it must decrease the merit
    function itself, where the non-monotone reference (the largest of the last values) would
    let a period-2 cycle of full steps go on (linesearch.REPEAT)."""
    from xfemcontact.solver import linesearch

    class Snes:
        k = 0

        def getIterationNumber(self):
            return self.k

    class Problem:
        merit_active = True

        def stall(self):
            raise AssertionError("no stall expected")

    snes = Snes()
    ls = linesearch.MeritLineSearch(snes, lambda v: float(v.getArray()[0]) ** 2, Problem())
    x, y = PETSc.Vec().createSeq(1), PETSc.Vec().createSeq(1)
    # the merit values 100, then 10 and 20 in turn: a period-2 cycle of full steps
    path = [10.0, 10.0 ** 0.5, 20.0 ** 0.5, 10.0 ** 0.5]
    damped = []
    for k, (a, b) in enumerate(zip(path, path[1:] + [20.0 ** 0.5])):
        snes.k = k
        x.set(a)
        y.set(a - b)                  # PETSc's step: the new iterate is x - y
        damped.append(ls(x, y))
    assert damped == [False, False, False, True]     # 10 met again: 20 is no decrease from it
    assert abs(y.getArray()[0]) < abs(path[3] - 20.0 ** 0.5)


def test_changed_equations_take_a_newton_iteration(tmp_path):
    """The arc under a stronger shear (dx = 4e-6 m): after Newton's convergence the status
    loop changes a status, and the next threshold iteration's Newton starts within
    RESI_GLOB_RELA of the changed equations.  It takes an iteration all the same
    (``equations_changed``), so that the answer satisfies the conditions at the dofs to
    round-off; accepting the start left them violated by 6.2e-9 of their scales."""
    text = (CASES / "campaign" / "curved_arc_shear_quad8.toml").read_text()
    case = tmp_path / "arc.toml"
    case.write_text(text.replace("dx = 2.0e-6", "dx = 4.0e-6"))
    p = run_cli(["run", case, "-o", tmp_path / "o"])
    assert p.returncode in (0, 1), p.stdout[-3000:] + p.stderr[-3000:]   # 1: its point-gap test
    r = results(tmp_path / "o")
    assert r["converged"]
    per_solve = r["iterations"]["newton_per_solve"]
    assert r["iterations"]["status_changes"][-2] > 0 and per_solve[-1] >= 1, r["iterations"]
    cond = r["conditions"]
    assert max(v for k, v in cond.items() if k not in ("pressure_scale_pa", "jump_scale_m")) <= 1e-13, cond


@pytest.mark.slow
def test_statuses_on_the_kink_within_newton_tolerance(tmp_path):
    """low_friction (SSNV509, mu = 0.3) refined to 160 x 160 QUAD8: a few dofs sit on the
    kink of the law (|T| = mu |LAGS_C|, slips of 5e-14 m) and their statuses switched stick
    <-> slip at every iteration while the residual stayed at 3e-14 of the loads: exit 3 at
    ITER_GLOB_MAXI.  A switch where both branches hold within Newton's tolerance no longer
    keeps Newton going; from the sticking start every condition then holds to round-off.
    (One dof of this mesh has a negative lumped weight from a gradient tie, -0.026 for a
    median of 0.035; it sticks at the bottom of the arc, so its tie is not merged
    (nodal_problem._positive_weights): merged, it cost 22 -> 76 Newton iterations.)"""
    text = (CASES / "validation" / "low_friction.toml").read_text()
    case = tmp_path / "low_friction_160.toml"
    case.write_text(text.replace("nx = 20, ny = 20", "nx = 160, ny = 160"))
    r = run_ok([case, "--no-plots", "-xfc_coarse_start", "NONE"], tmp_path / "o")
    assert r["converged"] and r["iterations"]["newton"] <= 25
    assert r["multipliers"]["convex_for_weight"] == 0
    cond = r["conditions"]
    assert max(v for k, v in cond.items() if not k.endswith(("_pa", "_m"))) <= 1e-12, cond


def test_threshold_steps_shorten_on_statuses_met_again():
    """The threshold update halves its step where statuses changed, and halves it once more
    each time the loop comes back to statuses it had in the load step (a cycle), down to
    1 / 2**(1 + MAX_HALVINGS); on the same statuses Anderson's update goes on."""
    from xfemcontact.contact import threshold

    upd = threshold.ThresholdUpdate(lambda a, b: float(np.dot(a, b)))
    s, target = np.array([-1.0]), np.array([-3.0])          # residual -2
    steps = [float(upd(s, target, key)[0] - s[0]) / -2.0 for key in "ABABABABA"]
    assert steps == [0.5, 0.5, 0.25, 0.25, 0.125, 0.125, 0.0625, 0.0625, 0.0625]
    assert threshold.MAX_HALVINGS == 3
    assert float(upd(s, target, "A")[0]) == -3.0               # same statuses: the plain update first


def _inclusion_variant(tmp_path, cell, level_set, sxx, syy, sxy, mu):
    """The floating inclusion of bench/inclusion_family.py on 24 x 24 ``cell`` with another
    interface, uniform stress (Pa) and Coulomb coefficient."""
    import re

    text = inclusion_case(tmp_path, cell, 24, 2.3).read_text()
    text = text.replace('"(x-xc)**2 + (y-yc)**2 - 2.3**2"', f'"{level_set}"')
    for key, value in (("sxx", sxx), ("syy", syy), ("sxy", sxy), ("coulomb", mu)):
        text, n = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
        assert n == 1, key
    case = tmp_path / f"variant_{cell}.toml"
    case.write_text(text)
    return case


@pytest.mark.slow
def test_a_status_cycle_of_the_threshold_loop_is_broken(tmp_path):
    """A circular inclusion held by friction alone, mu = 0.6, under sigma = (-100, -50, 40) Pa
    on 24 x 24 QUAD8: after the line search handed over to the threshold loop, the loop went
    round a cycle of 10 status sets until ITER_FROT_MAXI (exit 3 after 291 Newton
    iterations).  With the step shortened on statuses met again it converges (92)."""
    case = _inclusion_variant(tmp_path, "QUAD8", "(x-xc)**2 + (y-yc)**2 - 2.3**2", -100.0, -50.0, 40.0, 0.6)
    p = run_cli(["run", case, "-o", tmp_path / "out", "--no-plots"])
    r = results(tmp_path / "out")
    assert p.returncode in (0, 1) and r["converged"], p.stdout[-2000:]
    assert not any("CONTACT3_86" in w for w in r["warnings"]), r["warnings"]
    assert r["iterations"]["newton"] <= 120
    cond = {k: v for k, v in r["conditions"].items() if k not in ("pressure_scale_pa", "jump_scale_m") and v is not None}
    assert max(cond.values()) <= 1e-12, cond


@pytest.mark.slow
def test_the_coarse_start_keeps_to_its_budget(tmp_path):
    """A tilted elliptic inclusion, mu = 0.6, under sigma = (-100, 50, 10) Pa on 24 x 24 TRIA6:
    the stable space's threshold loop cycled for 309 Newton iterations before the run went on
    from the sticking start (345 in all).  The coarse start is a start: at most
    COARSE_ITER_FROT threshold iterations to RESI_FROT COARSE_RESI_FROT; it then converges and
    the run takes 69."""
    from xfemcontact import model

    case = _inclusion_variant(tmp_path, "TRIA6",
                              "((0.8*(x-xc)+0.6*(y-yc))/2.8)**2 + ((-0.6*(x-xc)+0.8*(y-yc))/1.8)**2 - 1",
                              -100.0, 50.0, 10.0, 0.6)
    p = run_cli(["run", case, "-o", tmp_path / "out", "--no-plots"])
    r = results(tmp_path / "out")
    assert p.returncode in (0, 1) and r["converged"], p.stdout[-2000:]
    start = r["iterations"]["coarse_start"]
    assert start["threshold_iterations"] <= model.COARSE_ITER_FROT
    assert r["iterations"]["newton"] <= 100
    cond = {k: v for k, v in r["conditions"].items() if k not in ("pressure_scale_pa", "jump_scale_m") and v is not None}
    assert max(cond.values()) <= 1e-12, cond


@pytest.mark.slow
def test_the_first_step_of_a_load_history_takes_the_coarse_start(tmp_path):
    """The first step of a load history is a single-step problem with that step's loads: the
    coarse start applies to it too (case_at the step's instant).  A tilted elliptic inclusion,
    mu = 0.6, under sigma = (-100, 50, 10) Pa on 24 x 24 QUAD8, loaded in 0.5, 1, then unloaded
    to 0.3 and reloaded: the first step did not converge, even cut three times (the problem is
    the same at any scale), exit 3 after 620 Newton iterations; now every step converges."""
    case = _inclusion_variant(tmp_path, "QUAD8",
                              "((0.8*(x-xc)+0.6*(y-yc))/2.8)**2 + ((-0.6*(x-xc)+0.8*(y-yc))/1.8)**2 - 1",
                              -100.0, 50.0, 10.0, 0.6)
    text = case.read_text().replace("[[traction]]\n", '[[traction]]\nfonc_mult = "ramp"\n')
    text = text.replace("[interface]", "[instants]\nranges = [{ start = 0.0, end = 1.0, steps = 2 }, "
                        "{ start = 1.0, end = 3.0, steps = 4 }]\n\n[functions]\n"
                        "ramp = { vale = [0.0, 0.0, 1.0, 1.0, 2.0, 0.3, 3.0, 1.0] }\n\n[interface]")
    assert text.count('fonc_mult = "ramp"') == 3
    case.write_text(text)
    p = run_cli(["run", case, "-o", tmp_path / "out", "--no-plots"])
    r = results(tmp_path / "out")
    assert p.returncode in (0, 1) and r["converged"], p.stdout[-2000:] + p.stderr[-2000:]
    assert len(r["steps"]) == 6 and r["iterations"]["coarse_start"]["used"]
    cond = {k: v for k, v in r["conditions"].items() if k not in ("pressure_scale_pa", "jump_scale_m") and v is not None}
    assert max(cond.values()) <= 1e-12, cond
