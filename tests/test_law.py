"""The pointwise contact and friction law (xfemcontact.contact.gauss_point)."""

import numpy as np
import pytest

from xfemcontact.contact import gauss_point as claw

LAWS = {
    "semi-multiplier": claw.PointLaw(coef_cont=100.0, coef_frot=50.0, mu=0.4, friction=True),
    "traction": claw.PointLaw(coef_cont=100.0, coef_frot=50.0, mu=0.4, friction=True,
                         unknown="traction", rho_T=80.0),
}


def states(n=400, seed=3):
    """Random points: in contact or not, thresholds zero or compressive, stick and slip."""
    rng = np.random.default_rng(seed)
    chi = rng.integers(0, 2, n)
    s = np.where(rng.random(n) < 0.2, 0.0, -rng.uniform(1.0, 10.0, n))
    g, ut = rng.normal(0, 0.01, n), rng.normal(0, 0.02, n)
    lam, Lam = rng.normal(-1.0, 1.0, n), rng.normal(0.0, 1.5, n)
    return chi, s, g, ut, lam, Lam


@pytest.mark.parametrize("form", LAWS)
def test_tangent_is_the_derivative_of_the_residual(form):
    """Every tangent coefficient matches a central difference of the residual
    coefficients (away from the stick/slip kink), and the tangent is symmetric."""
    law = LAWS[form]
    chi, s, g, ut, lam, Lam = states()
    t = claw.point_terms(law, chi, s, g, ut, lam, Lam)
    h = 1e-7

    def d(key, var):
        args = dict(g=g, ut=ut, lam=lam, Lam=Lam)
        plus, minus = dict(args), dict(args)
        plus[var], minus[var] = args[var] + h, args[var] - h
        return (claw.point_terms(law, chi, s, **plus)[key] - claw.point_terms(law, chi, s, **minus)[key]) / (2 * h)

    trial = (Lam - law.coef_frot * ut) if form == "semi-multiplier" else (Lam + law.rho_T * ut)
    bound = 1.0 if form == "semi-multiplier" else np.abs(law.mu * s)
    smooth = np.abs(np.abs(trial) - bound) > 1e-3 * np.maximum(bound, 1.0)
    for key, var, coef in (("rg", "g", "gg"), ("rg", "lam", "gl"), ("rl", "g", "gl"), ("rl", "lam", "ll"),
                           ("rt", "ut", "tt"), ("rt", "Lam", "tL"), ("rL", "ut", "tL"), ("rL", "Lam", "LL")):
        assert np.allclose(d(key, var)[smooth], t[coef][smooth], rtol=1e-6, atol=1e-6), (key, var)


def test_friction_inactive_without_contact_or_threshold():
    law = LAWS["semi-multiplier"]
    chi, s, g, ut, lam, Lam = states()
    t = claw.point_terms(law, chi, s, g, ut, lam, Lam)
    off = (chi == 0) | (s == 0)
    assert np.array_equal(t["rL"][off], Lam[off])          # Lam dLam: Lam = 0
    assert not t["rt"][off].any() and not t["slip"][off].any()
    assert np.array_equal(t["rl"][chi == 0], -lam[chi == 0] / law.coef_cont)


@pytest.mark.parametrize("form", LAWS)
def test_stick_mask_holds_slipping_points_in_the_stick_branch(form):
    """The stick predictor: held points get the stick branch, linear in (ut, Lam)."""
    law = LAWS[form]
    n = 50
    chi, s = np.ones(n, int), np.full(n, -5.0)
    g, lam = np.zeros(n), np.full(n, -5.0)
    ut = np.linspace(0.5, 1.0, n) * np.where(np.arange(n) % 2, 1.0, -1.0)   # far outside the cone: slip
    Lam = np.zeros(n)
    free = claw.point_terms(law, chi, s, g, ut, lam, Lam)
    assert free["slip"].all()
    held = claw.point_terms(law, chi, s, g, ut, lam, Lam, held=np.zeros(n))
    assert not held["slip"].any()
    stick = claw.point_terms(law, chi, s, g, 1e-9 * ut, lam, Lam)      # a genuine stick state
    for key in ("tt", "tL", "LL"):
        assert np.allclose(held[key], stick[key])
    # residual linear in ut: doubling ut doubles rt (Lam = 0)
    twice = claw.point_terms(law, chi, s, g, 2 * ut, lam, Lam, held=np.zeros(n))
    assert np.allclose(twice["rt"], 2 * held["rt"])


def test_status_test_and_threshold():
    law = LAWS["semi-multiplier"]
    chi = np.array([0, 0, 1, 1])
    g = np.array([-1e-6, 1e-6, 0.0, 1e-3])
    lam = np.array([0.0, 0.0, -1.0, -0.01])
    assert list(claw.update_status(law, chi, g, lam)) == [1, 0, 1, 0]
    assert list(claw.threshold(np.array([-2.0, 1e-12, 0.0]))) == [-2.0, 0.0, 0.0]


def test_nodal_friction_status_uses_the_trial_traction():
    """The friction statuses at the multiplier dofs (xfemcontact.contact.nodal): the
    augmented test on the trial traction T + rho_T gt, without direct reversal."""
    from xfemcontact.contact import nodal

    rho_T = 1e3                                         # Pa/m
    bound = np.full(7, 2.0)                             # mu |s|, Pa
    active = np.array([True] * 6 + [False])
    slip = np.array([0.0, 0.0, 0.0, 1.0, 1.0, -1.0, 1.0])
    T = np.array([1.0, 1.0, -3.0, 2.0, 2.0, -2.0, 2.0])
    gt = np.array([0.0, 2e-3, 0.0, 1e-4, -1e-4, 1e-2, 1e-3])
    new = nodal.friction_status(slip, active, T, gt, bound, rho_T)
    # 0: stick, |T| <= bound, no slip: stays; 1: stick but the trial 1 + 2 exceeds 2: slips
    # forward; 2: stick with |T| > bound: slips along T; 3: slipping forward: stays;
    # 4: slipping backwards, trial 1.9 within the bound: sticks; 5: the trial +8 points
    # against the slip -1: sticks (no reversal); 6: friction inactive
    assert list(new) == [0.0, 1.0, -1.0, 1.0, 0.0, 0.0, 0.0]
    # friction unbounded (the first solve without SEUIL_INIT): every active dof sticks
    free = nodal.friction_status(slip, active, T, gt, np.full(7, np.inf), rho_T)
    assert not free.any()
    # at a converged slipping state (T = bound p, slip along p) the status does not
    # depend on rho_T
    for r in (1e-6, 1.0, 1e12):
        assert nodal.friction_status(np.array([1.0]), np.array([True]), np.array([2.0]),
                                     np.array([1e-9]), np.array([2.0]), r)[0] == 1.0


def test_threshold_update_converges_on_affine_maps_and_halves_after_status_changes():
    """The Anderson-accelerated threshold update (xfemcontact.contact.threshold): on an
    affine map s -> A s + b with a spectral radius near 1 (a friction threshold fixed point
    at the Coulomb limit) it reaches the fixed point in a few steps where the plain update
    takes hundreds; a changed status key gives a half step towards the target."""
    from xfemcontact.contact.threshold import ThresholdUpdate

    rng = np.random.default_rng(5)
    n = 6
    P = rng.uniform(0.1, 1.0, (n, n))
    A = 0.97 * P / P.sum(axis=1, keepdims=True)      # non-negative, spectral radius 0.97
    b = -rng.uniform(1.0, 2.0, n)
    exact = np.linalg.solve(np.eye(n) - A, b)
    assert (exact < 0).all()
    update = ThresholdUpdate(lambda u, v: float(np.dot(u, v)))
    s = np.full(n, -1.0)
    s = update(s, A @ s + b, "statuses")             # the first call of a key: a half step
    assert np.allclose(s, np.minimum(-1.0 + 0.5 * (A @ np.full(n, -1.0) + b + 1.0), 0.0))
    for k in range(12):
        s = update(s, A @ s + b, "statuses")
    assert np.abs(s - exact).max() < 1e-10 * np.abs(exact).max()
    plain = np.full(n, -1.0)
    for k in range(12):
        plain = A @ plain + b
    assert np.abs(plain - exact).max() > 1e-2 * np.abs(exact).max()
