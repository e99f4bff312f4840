"""Contact and Coulomb friction written at the multiplier dofs (``integration = "NOEUD"``).

Each multiplier dof ``a`` (a carrier of :mod:`xfemcontact.contact.space`, whose
function phi_a >= 0 on the interface) holds the contact pressure lam_a =
LAGS_C (Pa, negative in compression) and the tangential traction T_a (Pa); the
interface tractions are lam(x) = sum phi_a lam_a and T(x) = sum phi_a T_a, whose
virtual work int lam d[u].n + T d[u].tau enters the equilibrium (the Galerkin
coupling, integrated at the interface Gauss points).  The kinematics of a dof are
its weights (m):

* D_a = int phi_a ds > 0 (lumped weight);
* mean gap ``gn_a = int phi_a [u].n ds / D_a`` and mean slip
  ``gt_a = int phi_a [u].tau ds / D_a`` (m; tau code_aster's tangent).

The conditions hold at each dof, with the friction threshold s_a (Pa, <= 0):

* contact: lam_a <= 0, gn_a >= 0, lam_a gn_a = 0;
* Coulomb (Tresca for a fixed s): |T_a| <= mu |s_a|; stick (gt_a = 0) or slip
  with T_a = mu |s_a| sign(gt_a).

That is the augmented complementarity lam_a = min(0, lam_a + rho_n gn_a),
T_a = proj_[-mu|s_a|, mu|s_a|](T_a + rho_T gt_a) (Alart and Curnier), whose
solutions do not depend on rho_n, rho_T > 0.  It is solved by active sets
(primal-dual active sets, i.e. a semi-smooth Newton method: Hueeber and
Wohlmuth 2005): for given statuses the problem is linear,

* active contact: the row of lam_a is the weighted gap ``D_a gn_a = 0`` and
  lam_a enters the equilibrium; inactive: ``-D_a lam_a / rho_n = 0``, lam_a is out
  of the equilibrium;
* stick: the row of T_a is the weighted slip ``D_a gt_a = 0`` and T_a enters
  the equilibrium; slip (p = +-1): ``D_a (T_a - mu |s_a| p) / rho_T = 0`` and the
  fixed traction mu |s_a| p enters the equilibrium; friction inactive (no
  contact, or no threshold): ``D_a T_a / rho_T = 0``;

symmetric, and rho_n, rho_T only scale the rows of inactive and slipping dofs.
The statuses then follow from the solution.  Contact, by rules that do not
involve the coefficients: an active dof is released when lam_a > 0 (tension), an
inactive one enters contact when gn_a < 0 (interpenetration).  Friction, by the
augmented test of the same complementarity, with one change: with the trial
traction T_a + r gt_a (Pa; r a fixed multiple of E/h, not COEF_FROT, see
:data:`xfemcontact.contact.nodal_problem.STATUS_SCALE`), a dof slips in its
direction where it exceeds the bound mu |s_a| and sticks where it does not,
except that a slipping dof whose trial traction points against its slip
direction sticks instead of reversing at once.  (The direct reversal of the
plain augmented test is what makes full-step Newton cycle on friction; the
trial traction, instead of the dof's traction alone, is what lets a dof that has
started slipping within an iteration, or one whose bound has grown, settle in
one Newton step: measured on the sliding campaign, 82 -> 41, 120 -> 52 and
121 -> 61 Newton iterations on the curved cases, 74 -> 37 at the Coulomb limit.)  At a converged
state the slipping dofs hold T_a = mu |s_a| p exactly and slip in the direction
p, the sticking ones hold |T_a| <= mu |s_a| and gt_a = 0: r only decides the path.

At a converged state every condition holds exactly at the dofs; LAGS_C(x) =
sum phi_a lam_a <= 0 and LAGS_F1(x) = sum phi_a Lam_a (Lam_a = T_a / (mu s_a), the
semi-multiplier, |Lam_a| <= 1) are then admissible at every interface point,
phi_a being non-negative.

Arrays here are per dof (any shape, all the same); statuses: ``chi`` 1 in
contact, 0 not; ``slip`` 0 stick, +-1 slip direction (also 0 where friction is
inactive).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]

#: relative round-off allowed in the status tests (a value within it of a
#: bound does not change a status)
ROUNDOFF = 1e-12


def contact_status(chi: IntArray, lam: FloatArray, gn: FloatArray, tol_lam: float,
                   tol_gap: float) -> IntArray:
    """New contact statuses: release where lam > tol_lam, enter where gn < -tol_gap."""
    new = chi.copy()
    new[(chi == 1) & (lam > tol_lam)] = 0
    new[(chi == 0) & (gn < -tol_gap)] = 1
    return new


def friction_status(slip: FloatArray, active: BoolArray, T: FloatArray, gt: FloatArray,
                    bound: FloatArray, rho_T: float, tol_slip: float = 0.0) -> FloatArray:
    """New friction statuses of dofs with statuses ``slip`` (0 stick, +-1).

    ``active``: friction on (in contact with a non-zero threshold); ``bound``:
    mu |s| (Pa; inf: unbounded, every active dof sticks); ``T`` (Pa) and ``gt`` (m):
    the dof traction and mean slip; ``rho_T`` (Pa/m); ``tol_slip`` (m): the
    round-off of the slips.  With the trial traction ``T + rho_T gt``: slip in its
    direction where its magnitude exceeds the bound, stick otherwise, and a slipping
    dof whose trial traction points against its slip sticks (no direct reversal).
    The tests leave a round-off band of ROUNDOFF x the bound plus rho_T x
    ``tol_slip`` on either side, so that a dof at the bound with a slip of
    round-off (a stick/slip limit reached exactly) keeps its status, and a
    converged slipping dof (T at the bound, slip along it) keeps it whatever rho_T.
    """
    trial = T + rho_T * gt
    finite = np.isfinite(bound)                 # unbounded: every active dof sticks
    b = np.where(finite, bound, 0.0)
    band = b * ROUNDOFF + rho_T * tol_slip
    starts = np.where(finite & (np.abs(trial) > b + band), np.sign(trial), 0.0)
    goes_on = np.where(finite & (slip * trial >= b - band), slip, 0.0)
    return np.where(active, np.where(slip == 0, starts, goes_on), 0.0)


def terms(chi: IntArray, slip: FloatArray, active: BoolArray, lam: FloatArray, T: FloatArray,
          bound: FloatArray, D: FloatArray, rho_n: float, rho_T: float, D_T: FloatArray | None = None,
          sliding: BoolArray | None = None, carried: BoolArray | None = None) -> dict[str, FloatArray]:
    """Coefficients of the nodal equations for given statuses.

    The friction arguments (``slip``, ``active``, ``T``, ``bound``) may be per friction
    component (3-D: ``(k, 2 m)``, the components of the slip direction p and of T in
    the tangent basis; ``D_T`` the weights there, default ``D``; ``sliding`` which of
    them belong to a slipping dof, default ``slip != 0``).  ``carried``: friction slots
    whose traction in the equilibrium is the dof's own T in slip too (default none: a
    slipping dof's is the fixed mu |s| p; with T the row D (T - mu |s| p) / rho_T = 0
    still makes them equal at a solution, see
    :meth:`xfemcontact.contact.nodal_problem.NodalContactProblem._direction_coupling`).

    Returns a dict of arrays: ``cn``, ``ct`` (Pa): the normal and tangential
    tractions of the dof in the equilibrium (they multiply d(D gn) and d(D gt));
    ``wn``, ``wt`` (1 or 0): whether the row of lam / T is the weighted gap /
    slip; ``rl``, ``rT``: the rest of the row of lam / T (the constant part, for
    inactive and slipping dofs); ``kl``, ``kT``: d rl / d lam, d rT / d T.
    """
    on = chi.astype(bool)
    slips = active & (slip != 0) if sliding is None else active & sliding
    stick = active & ~slips
    DT = D if D_T is None else D_T
    fixed = np.where(slips, np.where(np.isfinite(bound), bound, 0.0) * slip, 0.0)
    own = stick if carried is None else stick | (slips & carried)
    return {
        "cn": np.where(on, lam, 0.0),
        "wn": on.astype(float),
        "rl": np.where(on, 0.0, -D * lam / rho_n),
        "kl": np.where(on, 0.0, -D / rho_n),
        "ct": np.where(own, T, fixed),
        "wt": stick.astype(float),
        "rT": np.where(stick, 0.0, DT * (T - fixed) / rho_T),
        "kT": np.where(stick, 0.0, DT / rho_T),
    }


def friction_direction(p: FloatArray, active: BoolArray, T: FloatArray, gt: FloatArray,
                       bound: FloatArray, rho_T: float, tol_slip: float = 0.0,
                       direction_scale: float | None = None) -> FloatArray:
    """3-D: new friction statuses ``(..., 2)`` of dofs with statuses ``p (..., 2)`` (zero:
    stick; a unit vector of the tangent plane: slip in that direction), the rule of
    :func:`friction_status` for vectors.  ``T`` (Pa) and ``gt`` (m), ``(..., 2)``: the
    traction and the mean slip in the tangent basis; ``active``, ``bound`` ``(...)``.
    With the trial traction ``T + rho_T gt``: a sticking dof slips, in the direction of
    the trial traction, where its magnitude exceeds the bound; a slipping dof goes on
    slipping, in the trial traction's direction (with the threshold fixed point the slip
    direction is a status updated at each Newton iteration, so that each Newton step is
    linear; with Coulomb's law in Newton a function of the iterate, see
    ``direction_scale``), while the trial traction's component along its direction
    reaches the bound, and sticks otherwise (no direct reversal).  Round-off bands as in :func:`friction_status`.
    ``direction_scale`` (Pa/m): the new directions are those of T + direction_scale gt
    instead (the slip direction as a function of the iterate, in Newton's tangent:
    at a solution T and gt are both along p, so either scale gives the same directions)."""
    trial = T + rho_T * gt
    mag = np.linalg.norm(trial, axis=-1)
    finite = np.isfinite(bound)                 # unbounded: every active dof sticks
    b = np.where(finite, bound, 0.0)
    band = b * ROUNDOFF + rho_T * tol_slip
    unit = _unit(trial)
    if direction_scale is not None:
        own = _unit(T + direction_scale * gt)
        unit = np.where(np.any(own != 0, axis=-1)[..., None], own, unit)
    starts = finite & (mag > b + band)
    goes_on = finite & (np.einsum("...c,...c->...", p, trial) >= b - band)
    sliding = np.any(p != 0, axis=-1)
    new = np.where(sliding, goes_on, starts) & active
    return np.where(new[..., None], unit, 0.0)


def _unit(v: FloatArray) -> FloatArray:
    """The unit vectors of ``v (..., c)`` (0 where v = 0)."""
    mag = np.linalg.norm(v, axis=-1)
    return np.where((mag > 0)[..., None], v / np.where(mag > 0, mag, 1.0)[..., None], 0.0)


def direction_derivative(trial: FloatArray, bound: FloatArray) -> FloatArray:
    """3-D: the derivative ``(..., 2, 2)`` (Pa/Pa) of the slipping traction b p, p = q / |q|,
    with respect to the trial traction q: b (I - p p^T) / |q|, at the trial tractions
    ``trial (..., 2)`` (Pa, in the tangent basis) and bounds ``bound (...)`` (Pa, b = mu |s|);
    0 where q = 0.  Its eigenvalues are 0 (along p: the magnitude stays b) and b / |q|
    (across: the direction turns), at most 1 + ROUNDOFF for a dof that slips."""
    mag = np.linalg.norm(trial, axis=-1)
    safe = np.where(mag > 0, mag, 1.0)
    p = trial / safe[..., None]
    across = np.eye(trial.shape[-1]) - p[..., :, None] * p[..., None, :]
    return np.where((mag > 0)[..., None, None], (bound / safe)[..., None, None] * across, 0.0)


def threshold(lam: FloatArray, scale: float) -> FloatArray:
    """New friction thresholds s = min(lam, 0), 0 where |lam| <= ROUNDOFF * scale."""
    s = np.minimum(lam, 0.0)
    return np.where(np.abs(s) <= ROUNDOFF * scale, 0.0, s)


def semi_multiplier(T: FloatArray, s: FloatArray, mu: float) -> FloatArray:
    """LAGS_F1 = T / (mu s) (0 where mu s = 0): the traction as code_aster's semi-multiplier."""
    musig = mu * s
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(musig != 0, T / np.where(musig != 0, musig, 1.0), 0.0)


def contact_status_augmented(chi: IntArray, lam: FloatArray, gn: FloatArray, r: float, tol_lam: float,
                             tol_gap: float) -> IntArray:
    """Contact statuses of the augmented test at the iterate alone (the branch of
    :func:`complementarity`'s min): in contact where lam + r gn < 0, out where > 0; within
    the round-off band tol_lam + r tol_gap of zero a dof keeps its status ``chi``."""
    q = lam + r * gn
    band = tol_lam + r * tol_gap
    return np.where(q < -band, 1, np.where(q > band, 0, chi)).astype(chi.dtype)


def friction_status_augmented(slip: FloatArray, active: BoolArray, T: FloatArray, gt: FloatArray,
                              bound: FloatArray, r: float, tol_slip: float = 0.0) -> FloatArray:
    """Friction statuses of the augmented test at the iterate alone (the branch of
    :func:`complementarity`'s projection): slip in the direction of the trial traction
    T + r gt where its magnitude exceeds the bound, stick where it does not -- a direct
    reversal included, so that the status is a function of the iterate.  Within the
    round-off band of :func:`friction_status` a dof keeps a slip along the trial traction if
    it has slipped in the step (``|gt|`` above ``tol_slip``); one that has not sits on the kink
    of the projection, where both branches are Newton's, and sticks: at the start of a load
    step every slipping dof is there (gt = 0, |T| = b), and the stick branch is the elastic
    predictor, which an unloading step needs (cases/validation/history_shear_cycle.toml: the
    slip branch there reversed the slip at every iteration, 17 Newton iterations in the step
    after a forward slip, 50 over the cycle; 22 over the cycle with the stick branch)."""
    trial = T + r * gt
    finite = np.isfinite(bound)
    b = np.where(finite, bound, 0.0)
    band = b * ROUNDOFF + r * tol_slip
    new = np.where(finite & (np.abs(trial) > b + band), np.sign(trial), 0.0)
    keep = finite & (np.abs(trial) >= b - band) & (slip * trial > 0) & (np.abs(gt) > tol_slip)
    return np.where(active, np.where(keep, slip, new), 0.0)


def complementarity(lam: FloatArray, T: FloatArray, gn: FloatArray, gt: FloatArray, mu: float,
                    r: float, friction: bool = True) -> tuple[FloatArray, FloatArray]:
    """The conditions as functions of the iterate alone (Pa; Alart and Curnier's
    complementarity functions): ``C_n = lam - min(0, lam + r gn)`` and ``C_t = T -
    proj_[-b, b](T + r gt)`` with the augmented bound ``b = mu max(0, -(lam + r gn))`` (0
    without ``friction``: C_t = T).  Both vanish exactly at the solutions of the conditions,
    whatever r > 0 (where C_n = 0, either lam = 0 <= r gn and b = 0, or gn = 0 and b = -mu lam);
    the augmented bound, not mu |lam|, gives a dof that closes with lam = 0 (an interpenetration,
    a pressure still to come) the friction its penetration announces, so that Newton does not
    take it as frictionless for a step.  Newton's statuses with the same r
    (:func:`contact_status_augmented`, :func:`friction_status_augmented`) are the branches of
    the min and of the projection, so that Newton's step is the (generalised) Newton step of
    these functions and descends their squared norm."""
    q = lam + r * gn
    cn = lam - np.minimum(0.0, q)
    b = mu * np.maximum(0.0, -q) if friction else np.zeros_like(q)
    ct = T - np.clip(T + r * gt, -b, b)
    return cn, ct
