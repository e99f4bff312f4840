"""code_aster's continuous augmented-Lagrangian contact with Coulomb friction, at Gauss points.

At an interface Gauss point, with the jump [u] = u+ - u- (m), the unit normal
n (from - to +) and code_aster's tangent tau (non-negative x-component):

* gap ``g = [u].n`` (> 0 opening), tangential jump ``ut = [u].tau``;
* contact pressure ``lam`` = LAGS_C (Pa, negative in compression), friction
  semi-multiplier ``Lam`` = LAGS_F1 (dimensionless);
* status ``chi``: 1 in contact, 0 not; threshold ``s`` (Pa, negative in
  compression, from the previous threshold iteration).

Weak form per unit length (rho_n = COEF_CONT in Pa/m, rho_t = COEF_FROT in
1/m, used as given, like code_aster):

* chi = 1: (lam + rho_n g) dg + g dlam;  chi = 0: -(lam / rho_n) dlam;
* friction active (chi = 1, mu s != 0), with the trial value
  ``gt = Lam - rho_t ut`` and its projection ``p`` on [-1, 1]:
  mu s p dut + (mu s / rho_t) (Lam - p) dLam;
* friction inactive: Lam dLam (so Lam = 0).

At convergence lam = sigma_nn and mu s Lam = sigma_nt: LAGS_F1 =
sigma_nt / (mu sigma_nn), |LAGS_F1| <= 1, = 1 in slip.

In 3-D (code_aster's continuous method with two friction directions) ``ut`` and
``Lam`` = (LAGS_F1, LAGS_F2) are vectors of the tangent plane, by their components in
the tangent basis (t1, t2) (``(..., 2)``), and the trial value ``gt = Lam - rho_t ut``
is projected on the unit disc: ``p = gt`` inside (stick), ``gt / |gt|`` outside (slip),
with the derivative (I - p p^T) / |gt| in slip (the direction turns, the magnitude
stays 1).  The weak form is the same with dot products; |(LAGS_F1, LAGS_F2)| = 1 in
slip.  :func:`disc_terms` is that form for any number of components; with one it is
the 2-D law above, operation for operation (:func:`point_terms` takes both).

Traction form (option ``friction_unknown = "TRACTION"``): the friction dof holds
the tangential traction T = mu s Lam (Pa) instead of Lam, with the trial
traction ``T + rho_T ut`` projected on [-mu |s|, mu |s|] (3-D: the disc of radius
mu |s|, derivative mu |s| (I - p p^T) / |T + rho_T ut| in slip) and a fixed
augmentation ``rho_T = max(COEF_CONT, mu COEF_FROT |SEUIL_INIT|)`` (Pa/m).  It is
the same law -- code_aster's trial value times mu s -- but the stick tangent no
longer depends on the threshold s: when the threshold loop updates s and every
point sticks, the matrix is unchanged and the converged solution stays
converged (SSNV509: one factorisation instead of two).  LAGS_F1 is reported as
T / (mu LAGS_C) at each point, which in slip zones is 1 only up to the
discretisation error (the default form gives exactly 1 there).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]

STICK_TOL = 1e-12          # |gt| <= 1 + STICK_TOL is stick (code_aster)
THRESHOLD_ZERO = 1e-11     # |s| below this (Pa) is taken as 0 (code_aster XREACL)


@dataclass
class PointLaw:
    """The coefficients of the law at the Gauss points."""
    coef_cont: float       # rho_n, Pa/m
    coef_frot: float       # rho_t, 1/m
    mu: float              # Coulomb coefficient (0: frictionless)
    friction: bool
    unknown: str = "semi-multiplier"   # "semi-multiplier" (Lam, code_aster) or "traction" (T, Pa)
    rho_T: float = 1.0     # traction form: fixed augmentation, Pa/m


def point_terms(law: PointLaw, chi: IntArray, s: FloatArray, g: FloatArray, ut: FloatArray,
                lam: FloatArray, Lam: FloatArray,
                held: FloatArray | None = None) -> dict[str, FloatArray]:
    """Coefficients of the residual and tangent at every point.

    ``chi``, ``s``, ``g``, ``lam`` ``(...)``: statuses, thresholds (Pa), gaps (m), LAGS_C (Pa).
    ``ut``, ``Lam``: the tangential jump (m) and the friction dof, either ``(...)`` (one
    tangent: 2-D, code_aster's tau) or ``(..., nf)`` (their components in a tangent basis,
    nf = d - 1: 3-D, (t1, t2)); the friction entries of the result have the same form.
    ``held``: optional friction statuses imposed on the points, of the form of ``ut`` (0
    stick, a unit direction: slip along it, NaN: the trial value decides), see
    :func:`friction_status` and :mod:`xfemcontact.solver.loops` (stick predictor, frozen
    statuses).

    Returns a dict of arrays: ``rg`` (coefficient of dg), ``rl`` (of dlam), ``rt`` (of dut),
    ``rL`` (of dLam), and tangent coefficients ``gg, gl, ll`` (d rg/dg, d rg/dlam, d rl/dlam)
    and ``tt, tL, LL`` (d rt/dut, d rt/dLam = (d rL/dut)^T, d rL/dLam: ``(...)`` for one
    tangent, ``(..., nf, nf)`` for components), and the mask ``slip`` ``(...)``.
    """
    if np.ndim(ut) == np.ndim(chi):           # one tangent: the components' form with nf = 1
        t = disc_terms(law, chi, s, g, ut[..., None], lam, Lam[..., None],
                       None if held is None else held[..., None])
        for key in ("rt", "rL"):
            t[key] = t[key][..., 0]
        for key in ("tt", "tL", "LL"):
            t[key] = t[key][..., 0, 0]
        return t
    return disc_terms(law, chi, s, g, ut, lam, Lam, held)


def disc_terms(law: PointLaw, chi: IntArray, s: FloatArray, g: FloatArray, ut: FloatArray,
               lam: FloatArray, Lam: FloatArray,
               held: FloatArray | None = None) -> dict[str, FloatArray]:
    """:func:`point_terms` with the friction fields as components ``ut``, ``Lam``, ``held``
    ``(..., nf)`` (nf = 1 in 2-D, 2 in 3-D): Coulomb's disc.

    The trial value ``q = Lam - rho_t ut`` is projected on the unit disc: ``p = q`` inside
    (stick), ``p = q / |q|`` outside (slip); the friction terms are mu s p . dut +
    (mu s / rho_t) (Lam - p) . dLam, whose tangent holds ``A = dp / dq``: I in stick,
    (I - p p^T) / |q| in slip (0 along p, 1 / |q| across; exactly 0 with one component),
    0 for a slip direction held fixed.  Contact terms as in the module documentation.
    """
    rho, rho_t, mu = law.coef_cont, law.coef_frot, law.mu
    on = chi.astype(bool)
    t = {
        "rg": np.where(on, lam + rho * g, 0.0),
        "rl": np.where(on, g, -lam / rho),
        "gg": np.where(on, rho, 0.0),
        "gl": np.where(on, 1.0, 0.0),
        "ll": np.where(on, 0.0, -1.0 / rho),
    }
    musig = mu * s
    active = on & law.friction & (np.abs(musig) > 0)
    status = friction_status(law, chi, s, ut, Lam, held)
    stick = ~np.any(status != 0, axis=-1)
    t["slip"] = active & ~stick
    free = np.isnan(held).any(axis=-1) if held is not None else np.ones(stick.shape, bool)
    if law.unknown == "traction":
        trial, bound = Lam + law.rho_T * ut, np.abs(musig)
    else:
        trial, bound = Lam - rho_t * ut, np.ones(musig.shape)
    A = projection_derivative(trial, bound, stick, free)                     # (..., nf, nf)
    if law.unknown == "traction":
        return _traction_terms(law, t, active, musig, ut, Lam, stick, status, A)
    a, m = active[..., None], active[..., None, None]
    I = np.eye(ut.shape[-1])
    p = np.where(stick[..., None], trial, status)          # the projected trial value
    t["rt"] = np.where(a, musig[..., None] * p, 0.0)
    t["rL"] = np.where(a, (musig / rho_t)[..., None] * (Lam - p), Lam)
    t["tt"] = np.where(m, (-musig * rho_t)[..., None, None] * A, 0.0)
    t["tL"] = np.where(m, musig[..., None, None] * A, 0.0)
    t["LL"] = np.where(m, (musig / rho_t)[..., None, None] * (I - A), I)
    return t


def projection_derivative(trial: FloatArray, bound: FloatArray, stick: BoolArray,
                          free: BoolArray) -> FloatArray:
    """The derivative ``(..., nf, nf)`` of the projection of the trial values ``trial (...,
    nf)`` on the discs of radius ``bound (...)``: I where ``stick``; b (I - p p^T) / |q|
    where a free point slips (p = q / |q|: 0 along p, the magnitude stays b; b / |q| across,
    the direction turns); 0 where a slip direction is held (``free`` False)."""
    nf = trial.shape[-1]
    I = np.eye(nf)
    mag = magnitude(trial)
    safe = np.where(mag > 0, mag, 1.0)
    p = trial / safe[..., None]
    across = I - p[..., :, None] * p[..., None, :]
    turn = across * (bound / safe)[..., None, None]
    slip = np.where(free[..., None, None], turn, 0.0)
    return np.where(stick[..., None, None], I, slip)


def magnitude(v: FloatArray) -> FloatArray:
    """|v| of components ``v (..., nf)`` (with one component |v_0| exactly)."""
    if v.shape[-1] == 1:
        return np.abs(v[..., 0])
    return np.sqrt(np.einsum("...c,...c->...", v, v))


def _traction_terms(law: PointLaw, t: dict[str, FloatArray], active: BoolArray, musig: FloatArray,
                    ut: FloatArray, T: FloatArray, stick: BoolArray, status: FloatArray,
                    A: FloatArray) -> dict[str, FloatArray]:
    """Friction terms with the tangential traction T (Pa, components ``(..., nf)``) as
    unknown: the trial traction T + rho_T ut projected on the disc of radius mu |s|, ``A``
    the derivative of that projection (:func:`projection_derivative`)."""
    rho = law.rho_T
    a, m = active[..., None], active[..., None, None]
    I = np.eye(ut.shape[-1])
    P = np.where(stick[..., None], T + rho * ut, np.abs(musig)[..., None] * status)   # the projected trial traction
    t["rt"] = np.where(a, P, 0.0)
    t["rL"] = np.where(a, -(T - P) / rho, -T / rho)
    t["tt"] = np.where(m, rho * A, 0.0)
    t["tL"] = np.where(m, A, 0.0)
    t["LL"] = np.where(m, -(I - A) / rho, -I / rho)
    return t


def friction_status(law: PointLaw, chi: IntArray, s: FloatArray, ut: FloatArray, Lam: FloatArray,
                    held: FloatArray | None = None) -> FloatArray:
    """Friction status of every point, of the form of ``ut`` (see :func:`point_terms`):
    0 stick (or friction inactive), the unit slip direction in slip (one tangent: +-1), from
    the trial value (LAGS_F1 - COEF_FROT ut against 1, or T + rho_T ut against mu |s|; its
    magnitude with components) unless ``held`` imposes it (not NaN there)."""
    if np.ndim(ut) == np.ndim(chi):
        return friction_status(law, chi, s, ut[..., None], Lam[..., None],
                               None if held is None else held[..., None])[..., 0]
    active = chi.astype(bool) & law.friction & (np.abs(law.mu * s) > 0)
    if law.unknown == "traction":
        trial, bound = Lam + law.rho_T * ut, np.abs(law.mu * s)
    else:
        trial, bound = Lam - law.coef_frot * ut, 1.0
    mag = magnitude(trial)
    unit = trial / np.where(mag > 0, mag, 1.0)[..., None]
    status = np.where((mag > bound * (1.0 + STICK_TOL))[..., None], unit, 0.0)
    if held is not None:
        status = np.where(np.isnan(held).any(axis=-1)[..., None], status, held)
    return np.where(active[..., None], status, 0.0)


def semi_multiplier(law: PointLaw, s: FloatArray, F: FloatArray) -> FloatArray:
    """LAGS_F1 (components: LAGS_F1, LAGS_F2) from the friction dof values ``F`` ``(...)``
    or ``(..., nf)`` at points with thresholds ``s (...)`` (Pa)."""
    if law.unknown != "traction":
        return F
    musig = law.mu * s
    if np.ndim(F) > np.ndim(s):
        musig = musig[..., None]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.abs(musig) > 0, F / musig, 0.0)


def update_status(law: PointLaw, chi: IntArray, g: FloatArray, lam: FloatArray,
                  gap_tol: float = 1e-16, release_tol: float = 2.2e-16) -> IntArray:
    """code_aster's status test after Newton: returns the new statuses.

    Not in contact -> in contact when it interpenetrates (-g > gap_tol);
    in contact -> released when lam + rho_n g > release_tol.
    """
    new = chi.copy()
    new[(chi == 0) & (-g > gap_tol)] = 1
    new[(chi == 1) & (lam + law.coef_cont * g > release_tol)] = 0
    return new


def threshold(lam: FloatArray) -> FloatArray:
    """New friction threshold s = lam (0 where |lam| < THRESHOLD_ZERO)."""
    return np.where(np.abs(lam) < THRESHOLD_ZERO, 0.0, lam)
