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

Traction form (option ``friction_unknown = "TRACTION"``): the friction dof holds
the tangential traction T = mu s Lam (Pa) instead of Lam, with the trial
traction ``T + rho_T ut`` projected on [-mu |s|, mu |s|] and a fixed
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
    """Coefficients of the residual and tangent at every point (arrays of one shape).

    ``held``: optional friction statuses imposed on the points (0 stick, +-1 slip
    in that direction, NaN: the trial value decides), see :func:`friction_status`
    and :mod:`xfemcontact.solver.loops` (stick predictor, frozen statuses).

    Returns a dict of arrays:
    ``rg`` (coefficient of dg), ``rl`` (of dlam), ``rt`` (of dut), ``rL`` (of dLam),
    and tangent coefficients ``gg, gl, ll, tt, tL, LL`` (d rg/dg, d rg/dlam,
    d rl/dlam, d rt/dut, d rt/dLam = d rL/dut, d rL/dLam).
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
    stick = status == 0
    kn = np.where(stick, 1.0, 0.0)
    t["slip"] = active & ~stick
    if law.unknown == "traction":
        return _traction_terms(law, t, active, musig, ut, Lam, stick, status)
    p = np.where(stick, Lam - rho_t * ut, status)        # the projected trial value
    t["rt"] = np.where(active, musig * p, 0.0)
    t["rL"] = np.where(active, (musig / rho_t) * (Lam - p), Lam)
    t["tt"] = np.where(active, -musig * rho_t * kn, 0.0)
    t["tL"] = np.where(active, musig * kn, 0.0)
    t["LL"] = np.where(active, (musig / rho_t) * (1.0 - kn), 1.0)
    return t


def _traction_terms(law: PointLaw, t: dict[str, FloatArray], active: FloatArray, musig: FloatArray,
                    ut: FloatArray, T: FloatArray, stick: FloatArray,
                    status: FloatArray) -> dict[str, FloatArray]:
    """Friction terms with the tangential traction T (Pa) as unknown."""
    rho = law.rho_T
    P = np.where(stick, T + rho * ut, np.abs(musig) * status)   # the projected trial traction
    kn = np.where(stick, 1.0, 0.0)
    t["rt"] = np.where(active, P, 0.0)
    t["rL"] = np.where(active, -(T - P) / rho, -T / rho)
    t["tt"] = np.where(active, rho * kn, 0.0)
    t["tL"] = np.where(active, kn, 0.0)
    t["LL"] = np.where(active, -(1.0 - kn) / rho, -1.0 / rho)
    return t


def friction_status(law: PointLaw, chi: IntArray, s: FloatArray, ut: FloatArray, Lam: FloatArray,
                    held: FloatArray | None = None) -> FloatArray:
    """Friction status of every point: 0 stick (or friction inactive), +-1 slip in
    that direction, from the trial value (LAGS_F1 - COEF_FROT ut against 1, or
    T + rho_T ut against mu |s|) unless ``held`` imposes it (not NaN there)."""
    active = chi.astype(bool) & law.friction & (np.abs(law.mu * s) > 0)
    if law.unknown == "traction":
        trial, bound = Lam + law.rho_T * ut, np.abs(law.mu * s)
    else:
        trial, bound = Lam - law.coef_frot * ut, 1.0
    status = np.where(np.abs(trial) > bound * (1.0 + STICK_TOL), np.sign(trial), 0.0)
    if held is not None:
        status = np.where(np.isnan(held), status, held)
    return np.where(active, status, 0.0)


def semi_multiplier(law: PointLaw, s: FloatArray, F: FloatArray) -> FloatArray:
    """LAGS_F1 from the friction dof values ``F`` at points with thresholds ``s``."""
    if law.unknown != "traction":
        return F
    musig = law.mu * s
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
