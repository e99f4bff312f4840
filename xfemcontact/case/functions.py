"""Functions of time in case files: code_aster's DEFI_FONCTION and loads at an instant.

:class:`Function` is a piecewise linear table ``(t_i, f_i)`` (``INTERPOL='LIN'``)
with code_aster's extensions outside its abscissae (PROL_GAUCHE on the left,
PROL_DROITE on the right):

* ``CONSTANT``: the value of the nearest end;
* ``LINEAIRE``: the line through the two nearest points;
* ``EXCLU``: no value (code_aster's default): evaluating there is an error,
  refused when the case is read (:func:`outside`).

A table of one point is constant (CONSTANT) or that point only.

:class:`TimeFormula` is a load value (or a reference formula) bound to an
instant: a formula of ``x``, ``y`` and ``t`` times the value of its FONC_MULT
function at that instant.  Called like a formula of ``x`` and ``y``, so the
assembly, the checks and the test tables evaluate it as they evaluate any
formula; :meth:`TimeFormula.at` gives the same load at another instant.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from xfemcontact.case.formula import Formula

EXTENSIONS = ("CONSTANT", "LINEAIRE", "EXCLU")


@dataclass(frozen=True)
class Function:
    """A piecewise linear function of time (DEFI_FONCTION, see the module documentation)."""

    name: str
    t: tuple                     # increasing abscissae
    f: tuple                     # values
    left: str = "EXCLU"          # PROL_GAUCHE
    right: str = "EXCLU"         # PROL_DROITE

    def __call__(self, t: float) -> float:
        """The value at ``t`` (a number); ValueError outside an EXCLU end."""
        ts, fs = np.asarray(self.t, float), np.asarray(self.f, float)
        t = float(t)
        if t < ts[0] or t > ts[-1]:
            side = self.left if t < ts[0] else self.right
            if side == "EXCLU":
                raise ValueError(f"{self.name}: instant {t:g} is outside [{ts[0]:g}, {ts[-1]:g}] "
                                 f"and prol_{'gauche' if t < ts[0] else 'droite'} = \"EXCLU\"")
            if side == "CONSTANT" or len(ts) == 1:
                return float(fs[0] if t < ts[0] else fs[-1])
            i = (0, 1) if t < ts[0] else (-2, -1)
            a, b = i
            return float(fs[a] + (fs[b] - fs[a]) * (t - ts[a]) / (ts[b] - ts[a]))
        if len(ts) == 1:
            return float(fs[0])
        j = int(np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(ts) - 2))
        if t == ts[j]:
            return float(fs[j])
        if t == ts[j + 1]:
            return float(fs[j + 1])
        return float(fs[j] + (fs[j + 1] - fs[j]) * (t - ts[j]) / (ts[j + 1] - ts[j]))

    def outside(self, instants: Iterable[float]) -> float | None:
        """The first of ``instants`` where the function has no value (EXCLU), or None."""
        lo, hi = self.t[0], self.t[-1]
        for t in instants:
            if (t < lo and self.left == "EXCLU") or (t > hi and self.right == "EXCLU"):
                return t
        return None


class TimeFormula:
    """A formula of x, y (and t) times a function of time, at an instant.

    ``formula``: a compiled :class:`~xfemcontact.case.formula.Formula` whose
    variables include ``t``; ``mult``: a :class:`Function` (FONC_MULT) or None;
    ``t``: the instant.  ``f(x=..., y=...)`` evaluates it; ``t`` is passed to the
    formula only when it uses it, so its messages name the same point as before.
    """

    def __init__(self, formula: Formula, mult: Function | None = None, t: float = 1.0) -> None:
        self.formula, self.mult, self.t = formula, mult, float(t)
        self.text = formula.text
        self.uses_time = "t" in formula.names or mult is not None

    @property
    def names(self) -> frozenset[str]:
        return self.formula.names

    @property
    def is_constant(self) -> bool:
        """Constant in x, y (it may still vary in time)."""
        return not (self.formula.names - {"t"})

    def value(self) -> float:
        """The value of a formula constant in x and y, at the bound instant."""
        if "t" in self.formula.names and self.is_constant:
            value = float(self.formula(t=self.t))
        else:
            value = self.formula.value()
        return value * self.mult(self.t) if self.mult is not None else value

    def at(self, t: float) -> TimeFormula:
        """The same value at instant ``t``."""
        return TimeFormula(self.formula, self.mult, t)

    def __call__(self, **xy: Any) -> Any:
        if "t" in self.formula.names:
            value = self.formula(t=self.t, **xy)
        else:
            value = self.formula(**xy)
        if self.mult is not None:
            value = value * self.mult(self.t)
        return value

    def __repr__(self) -> str:
        mult = f" * {self.mult.name}(t)" if self.mult is not None else ""
        return f"TimeFormula({self.text!r}{mult}, t={self.t:g})"
