"""Test tables like code_aster's TEST_TABLE: computed values against references.

A test reduces one field over a set of samples:

* ``interface`` fields (LAGS_C, LAGS_F1, gap, slip): the interface points
  (where the interface crosses cell edges), one sample per point and cell;
* ``node`` fields (DX, DY, [DZ]): the mesh nodes;
* ``cell`` fields (SIXX, SIYY, SIXY; in 3-D SIXX, SIYY, SIZZ, SIXY, SIXZ, SIYZ): the
  quadrature points of the cells (sub-cells of cut cells).

Types: MIN, MAX, SOMM_ABS (sum of absolute values), MAX_ERROR (largest
``|value - reference formula|``, reference 0), VALUE (the sample nearest to
``point``).  ``where`` keeps the samples where its condition holds.
Criterion ABSOLU: ``|value - reference| <= tolerance``; RELATIF:
``|value - reference| <= tolerance |reference|`` (for MAX_ERROR, relative to the
largest |reference formula| over the samples).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Iterable, Mapping

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray
    from petsc4py import PETSc

    from xfemcontact.case.formula import Formula
    from xfemcontact.case.functions import TimeFormula
    from xfemcontact.case.load import TestSpec

    FloatArray = NDArray[np.float64]


@dataclass
class Samples:
    """One process's samples of one kind: coordinates and field arrays (same length)."""

    x: FloatArray                     # (n,) m
    y: FloatArray                     # (n,) m
    fields: dict[str, FloatArray]     # field name -> (n,)
    z: FloatArray | None = None       # (n,) m, 3-D meshes

    def coordinates(self, keep: Any = slice(None)) -> dict[str, FloatArray]:
        """``{"x": ..., "y": ..., ["z": ...]}`` of the samples ``keep``."""
        out = {"x": self.x[keep], "y": self.y[keep]}
        if self.z is not None:
            out["z"] = self.z[keep]
        return out


@dataclass
class Outcome:
    """The result of one test (``at``: where the value was found, for MIN, MAX,
    VALUE and MAX_ERROR)."""
    name: str
    field: str
    type: str
    value: float
    reference: float
    tolerance: float
    criterion: str
    ok: bool
    count: int
    at: tuple[float, ...] | None = None       # (x, y) or (x, y, z)
    inst: float | None = None  # the instant tested (cases with [instants]), None otherwise

    @property
    def error(self) -> float:
        return abs(self.value - self.reference) if np.isfinite(self.value) else np.inf

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "field": self.field, "type": self.type, "value": self.value,
                "reference": self.reference, "error": self.error, "tolerance": self.tolerance,
                "criterion": self.criterion, "ok": self.ok, "samples": self.count,
                "at": list(self.at) if self.at is not None else None,
                **({"inst": self.inst} if self.inst is not None else {})}


def _local(test, s, ref_formula):
    """This process's part of ``test`` on samples ``s``: ``(count, value)``, the value
    with where it is found (a tuple, coordinates last) or None."""
    v = s.fields[test.field]
    keep = np.ones(len(v), dtype=bool)
    if test.where is not None and len(v):
        keep = np.asarray(test.where(**s.coordinates(), **s.fields), dtype=bool)
    v, xyz = v[keep], s.coordinates(keep)
    at = list(xyz.values())
    n = len(v)
    if test.type in ("MIN", "MAX"):
        if n == 0:
            return (n, None)
        i = int(np.argmin(v) if test.type == "MIN" else np.argmax(v))
        return (n, (float(v[i]), *(float(c[i]) for c in at)))
    if test.type == "SOMM_ABS":
        return (n, float(np.abs(v).sum()))
    if test.type == "MAX_ERROR":
        if n == 0:
            return (n, None)
        r = ref_formula(**xyz)
        i = int(np.argmax(np.abs(v - r)))
        return (n, (float(abs(v[i] - r[i])), *(float(c[i]) for c in at), float(np.abs(r).max())))
    # VALUE
    if n == 0:
        return (n, None)
    if len(at) == 2:
        d = np.hypot(at[0] - test.point[0], at[1] - test.point[1])
    else:
        d = np.sqrt(sum((c - p) ** 2 for c, p in zip(at, test.point)))
    i = int(np.argmin(d))
    return (n, (float(d[i]), float(v[i]), *(float(c[i]) for c in at)))


def _combine(test, parts):
    count = sum(p[0] for p in parts)
    vals = [p[1] for p in parts if p[1] is not None]
    if test.type == "SOMM_ABS":
        return count, float(sum(vals)), None, None
    if not vals:
        return count, np.nan, None, None
    if test.type == "MIN":
        v = min(vals)
        return count, v[0], tuple(v[1:]), None
    if test.type == "MAX":
        v = max(vals)
        return count, v[0], tuple(v[1:]), None
    if test.type == "MAX_ERROR":
        v = max(vals)
        return count, v[0], tuple(v[1:-1]), max(p[-1] for p in vals)
    v = min(vals)
    return count, v[1], tuple(v[2:]), None


def evaluate(tests: Iterable[TestSpec], samples: dict[str, Samples],
             reference: Mapping[str, Formula | TimeFormula],
             comm: PETSc.Comm) -> list[Outcome]:
    """Outcomes of ``tests`` (TestSpec) on all processes.

    ``samples``: {"interface"|"node"|"cell": Samples} of this process (a kind
    may be missing); ``reference``: {field: Formula or TimeFormula} (the case's
    reference formulas, at the instant of the tests).
    """
    mpi = comm.tompi4py()
    out = []
    for t in tests:
        s = samples.get(t.kind)
        local = _local(t, s, reference.get(t.field)) if s is not None else (0, None)
        count, value, at, ref_scale = _combine(t, mpi.allgather(local))
        ref = t.reference
        if t.criterion == "ABSOLU":
            allowed = t.tolerance
        else:
            allowed = t.tolerance * ((ref_scale or 0.0) if t.type == "MAX_ERROR" else abs(ref))
        ok = bool(count > 0 and np.isfinite(value) and abs(value - ref) <= allowed)
        out.append(Outcome(t.name, t.field, t.type, value, ref, t.tolerance, t.criterion, ok, count, at))
    return out


def table(outcomes: Iterable[Outcome]) -> list[str]:
    """The test table as text lines (code_aster-like); with an instant column when the
    outcomes name their instants."""
    outcomes = list(outcomes)
    timed = any(o.inst is not None for o in outcomes)
    head = f"{'inst':>10} " if timed else ""
    lines = [f"{'':4} {head}{'test':32} {'computed':>17} {'reference':>17} {'error':>10} {'tolerance':>10} criterion"]
    for o in outcomes:
        flag = "OK" if o.ok else "NOOK"
        if timed:
            flag = f"{flag:4} {o.inst:10.4g}" if o.inst is not None else f"{flag:4} {'':10}"
        if not np.isfinite(o.value):         # nothing to test: say so, not nan / inf
            what = "no point selected" if o.count == 0 else "not finite"
            lines.append(f"{flag:4} {o.name[:32]:32} {what:>17} {o.reference:17.10e} "
                         f"{'-':>10} {o.tolerance:10.2e} {o.criterion}")
            continue
        lines.append(f"{flag:4} {o.name[:32]:32} {o.value:17.10e} {o.reference:17.10e} "
                     f"{o.error:10.3e} {o.tolerance:10.2e} {o.criterion}")
    return lines
