"""The friction threshold fixed point s = LAGS_C(s), accelerated.

With the contact and friction statuses unchanged, LAGS_C depends affinely on
the thresholds (the slipping dofs carry mu |s| p), so the plain update s <- LAGS_C
converges only linearly, at a rate set by mu and the geometry (0.5 and slower
seen on straight interfaces at the Coulomb limit: 20 - 30 threshold iterations
to RESI_FROT = 1e-10).  Anderson's acceleration (mixing 1) takes the
combination of the last updates that minimises the fixed-point residual; on an
affine map it converges in a few steps.  The history is restarted whenever a
status changed (the map is then another affine map), and the accelerated
thresholds are kept compressive (<= 0) and zero where LAGS_C is.  Where a
status changed, the update is halved (the statuses and thresholds otherwise
wander or cycle around points at stick/slip or contact limits), and halved once more
each time the loop comes back to statuses it had before in the load step, down to
1 / 2**(1 + MAX_HALVINGS): a cycle of statuses is a cycle of the piecewise-affine map,
which shorter steps break.  The fixed point -- hence the answer -- is the same as the
plain update's.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Hashable, cast

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]

#: number of previous updates combined
DEPTH = 5
#: the most extra halvings of the update on statuses met again in the load step.  Measured
#: on a floating inclusion under sigma = (-100, -50, 40) Pa, mu = 0.6, 24 x 24 QUAD8 (a
#: status cycle of period 10 after the line search's hand-over, ITER_FROT_MAXI reached
#: after 291 Newton iterations): 92 Newton iterations with 3 or 10; of 56 curved cases one
#: other run changed (381 -> 368)
MAX_HALVINGS = 3


class ThresholdUpdate:
    """Anderson-accelerated s <- LAGS_C (see the module documentation).

    ``dot(a, b)``: the inner product of two arrays of thresholds over every
    process (each dof counted once).
    """

    s_hist: list[FloatArray]                # the last thresholds ...
    r_hist: list[FloatArray]                # ... and their residuals

    def __init__(self, dot: Callable[[FloatArray, FloatArray], float], depth: int = DEPTH) -> None:
        self.dot, self.depth = dot, depth
        self.s_hist, self.r_hist = [], []
        self.key: Hashable = None
        self.visits: dict[Hashable, int] = {}   # how often each status key came up in the step

    def restart(self) -> None:
        self.s_hist, self.r_hist = [], []

    def __call__(self, s: FloatArray, target: FloatArray, key: Hashable) -> FloatArray:
        """New thresholds from the current ones ``s`` and ``target`` (LAGS_C of the
        solve with ``s``); ``key``: anything that changes when a status does."""
        r = target - s
        if key != self.key:
            # statuses changed: a half step (the other affine map's fixed point may lie
            # anywhere; measured on the sliding campaign, damping only where the residual
            # grew took 37 threshold-loop Newton iterations on a limit case, 21 with it),
            # shorter if these statuses came up before (a cycle)
            self.restart()
            self.key = key
            before = self.visits.get(key, 0)
            self.visits[key] = before + 1
            step = 0.5 ** (1 + min(before, MAX_HALVINGS))
            # (NumPy's type information takes this product for a bool array)
            return cast("FloatArray", np.minimum(s + step * r, 0.0) * (target < 0))
        self.s_hist.append(s)
        self.r_hist.append(r)
        self.s_hist, self.r_hist = self.s_hist[-self.depth - 1:], self.r_hist[-self.depth - 1:]
        if len(self.r_hist) < 2:
            return target
        dR = [b - a for a, b in zip(self.r_hist[:-1], self.r_hist[1:])]
        dS = [b - a for a, b in zip(self.s_hist[:-1], self.s_hist[1:])]
        A = np.array([[self.dot(u, v) for v in dR] for u in dR])
        b = np.array([self.dot(u, r) for u in dR])
        if not (np.isfinite(A).all() and np.isfinite(b).all()):
            # an overflowed solve (the residual check of the next Newton reports it):
            # LAPACK must not see it
            self.restart()
            return target
        try:
            gamma = np.linalg.lstsq(A, b, rcond=1e-12)[0]
        except np.linalg.LinAlgError:
            self.restart()
            return target
        new = s + r - sum(g * (ds + dr) for g, ds, dr in zip(gamma, dS, dR))
        return np.where(target < 0, np.minimum(new, 0.0), 0.0)
