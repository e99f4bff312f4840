"""interface.csv: the interface point values along each interface curve.

Rows are the ends of the interface segments (the points where the interface
crosses cell edges, code_aster's NFISSU points), one row per point and cell
(the ``cell`` column: a point shared by two cells has both cells' values).
The segments are chained into curves: an open curve (boundary to boundary)
is walked from its end of least x (then least y) -- for SSNV509 from A (x = 0)
to C (x = 10); a closed curve from its point of least x (then y), with the
LN < 0 side on the left.  Curves are numbered by their first points in the
same order.  The curvilinear abscissa ``s`` (m) integrates the length along
the quadratic segments (the sum of their Gauss weights), so the last ``s`` of
a curve is its length.

Columns: curve, s (m), x, y (m), cell (input cell index), LAGS_C (Pa),
LAGS_F1 (-), gap, slip (m, normal and tangential jump), contact (1/0),
sliding (1/0); and ``<field>_ref``, ``<field>_err`` (computed - reference)
for each of LAGS_C, LAGS_F1, gap, slip with a ``[reference]`` formula.

3-D (:func:`build3d`): the interface is a surface; the rows are the Gauss points of
its facets (one row per point of non-zero weight), ordered by input cell and
point, columns x, y, z (m), cell, w (the point's area weight, m^2), LAGS_C (Pa),
LAGS_F1, LAGS_F2 (-: the tangential traction's components in the tangent basis
(t1, t2) over mu s), T (Pa, its magnitude), gap, slip1, slip2 (m, [u].n,
[u].t1, [u].t2), slip (m, the magnitude of the tangential jump), contact,
sliding, and the reference columns (formulas of x, y, z; LAGS_F2 too).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Protocol

import numpy as np

from xfemcontact.fem.elements import Seg3

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.case.formula import Formula
    from xfemcontact.case.functions import TimeFormula
    from xfemcontact.fem.elements import Element
    from xfemcontact.model import Model

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]
    #: {field: formula of x, y} (``[reference]``)
    References = Mapping[str, Formula | TimeFormula]

COLUMNS = ("curve", "s", "x", "y", "cell", "LAGS_C", "LAGS_F1", "gap", "slip", "contact", "sliding")
COLUMNS_3D = ("x", "y", "z", "cell", "w", "LAGS_C", "LAGS_F1", "LAGS_F2", "T", "gap", "slip1", "slip2", "slip",
              "contact", "sliding")
REFERENCE_FIELDS = ("LAGS_C", "LAGS_F1", "gap", "slip", "LAGS_F2")       # LAGS_F2: 3-D only
INTEGER_COLUMNS = ("curve", "cell", "contact", "sliding")
#: points per segment on the dense polylines drawn in the plots
DENSE = 9


class Folder(Protocol):
    """Where the file goes (an :class:`xfemcontact.output.folder.OutputFolder`, whose
    module imports the plots, which import this one)."""

    def file(self, name: str) -> Path: ...


@dataclass
class InterfaceTable:
    """The interface table of the whole model (rank 0)."""

    columns: dict[str, NDArray[Any]]      # name -> (rows,) in file order
    curves: list[dict[str, FloatArray]]   # per curve: {"x", "y", "s" (m), "<field>_ref"}: dense polylines
    length: float                         # total interface length, m
    warnings: list[str] = field(default_factory=list)


def build(model: Model) -> InterfaceTable | None:
    """The InterfaceTable on rank 0 (None elsewhere, or without an interface).  Collective."""
    v = model.interface_values()
    if v is None:
        return None
    if model.mesh.dim == 3:
        return build3d(model, v)
    problem, mesh = model.problem, model.mesh
    assert problem is not None                  # interface values come from the problem
    assert problem.segments is not None          # 2-D
    k = len(problem.segments)
    ends = {key: np.asarray(a).reshape(2, k).T for key, a in v.items()}       # (k, 2): P1, P2
    segs = problem.segments
    seg = {"cell": mesh.cell_ids[segs.cells], "length": problem.points.w.sum(axis=1),
           "xc": mesh.x[mesh.cell_nodes[segs.cells]], "nodes": segs.nodes}
    parts = model.comm.tompi4py().gather((ends, seg), root=0)
    if parts is None:
        return None
    ends = {key: np.concatenate([p[0][key] for p in parts]) for key in parts[0][0]}
    seg = {key: np.concatenate([p[1][key] for p in parts]) for key in parts[0][1]}
    order = np.argsort(seg["cell"], kind="stable")
    ends = {key: a[order] for key, a in ends.items()}
    seg = {key: a[order] for key, a in seg.items()}
    return tabulate(ends, seg, mesh.element, model.case.reference)


def build3d(model: Model, v: dict[str, NDArray[Any]]) -> InterfaceTable | None:
    """3-D: the table of the facets' Gauss points ``v`` of every process on rank 0
    (see the module documentation; ``length`` is the area, m^2).  Collective."""
    parts = model.comm.tompi4py().gather(v, root=0)
    if parts is None:
        return None
    allv = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    order = np.lexsort((allv["end"], allv["cell"]))
    cols = {c: allv[c][order] for c in COLUMNS_3D}
    table = InterfaceTable(cols, [], float(cols["w"].sum()))
    reference = model.case.reference
    for f in REFERENCE_FIELDS:
        formula = reference.get(f) if reference else None
        if formula is None:
            continue
        try:
            ref = np.broadcast_to(np.asarray(formula(x=cols["x"], y=cols["y"], z=cols["z"]), dtype=float),
                                  cols["x"].shape).copy()
        except Exception as exc:           # a formula invalid somewhere on the interface
            table.warnings.append(f"reference.{f}: not evaluated on the interface ({exc})")
            continue
        cols[f + "_ref"] = ref
        cols[f + "_err"] = cols[f] - ref
    return table


def tabulate(ends: dict[str, NDArray[Any]], seg: dict[str, NDArray[Any]], el: Element,
             reference: References | None) -> InterfaceTable:
    """Chain the segments and lay out the rows.

    ``ends``: point values ``(K, 2)`` at (P1, P2) of every segment (see
    ``InterfaceProblem.point_values``); ``seg``: ``cell (K,)``, ``length (K,)``
    (m), ``xc (K, nn, 2)`` parent coordinates, ``nodes (K, 3, 2)`` segment
    reference nodes; ``reference``: {field: Formula}.
    """
    # segments run P1 -> P2 with the LN > 0 side on the left: walk them P2 -> P1
    start = np.c_[ends["x"][:, 1], ends["y"][:, 1]]
    stop = np.c_[ends["x"][:, 0], ends["y"][:, 0]]
    curve, pos, rev = chain(start, stop)
    order = np.lexsort((pos, curve))
    curve, rev = curve[order], rev[order]
    L = seg["length"][order]
    cum = np.cumsum(L)
    first = np.r_[True, curve[1:] != curve[:-1]]
    base = np.maximum.accumulate(np.where(first, cum - L, 0.0))               # curve start offsets
    s1 = cum - base
    s0 = np.where(first, 0.0, np.r_[0.0, s1[:-1]])                           # exactly the previous end
    cols: dict[str, NDArray[Any]] = {"curve": np.repeat(curve, 2), "s": np.c_[s0, s1].ravel()}
    for key in ("x", "y", "LAGS_C", "LAGS_F1", "gap", "slip", "contact", "sliding"):
        v = ends[key][order]
        cols[key] = np.where(rev[:, None], v, v[:, ::-1]).ravel()             # walk start, walk end
    cols["cell"] = np.repeat(seg["cell"][order], 2)
    cols = {c: cols[c] for c in COLUMNS}
    curves = dense_curves(el, {k: a[order] for k, a in seg.items()}, curve, s0, rev)
    table = InterfaceTable(cols, curves, float(L.sum()))
    add_reference(table, reference)
    return table


def chain(start: FloatArray, stop: FloatArray) -> tuple[IntArray, IntArray, BoolArray]:
    """Order oriented segments ``start -> stop`` ``(K, 2)`` into curves.

    Points closer than the merge tolerance are one point.  An open curve is
    walked from its end of least x (then y), against the segments' orientation
    if need be; a closed one along it, from its point of least x (then y).
    Returns ``curve (K,)`` (numbered by their first points, in the same order),
    ``pos (K,)`` (position of each segment along its curve) and ``reverse
    (K,)`` (the segment is walked stop -> start).  Vectorised: pointer jumping.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from xfemcontact.post.points import merge_points

    K = len(start)
    if K == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, bool)
    pts = np.r_[start, stop]
    tol = 1e-9 * (float(np.hypot(*(pts.max(axis=0) - pts.min(axis=0)))) or 1.0)
    lab = merge_points(pts)
    a, b = lab[:K], lab[K:]
    idx = np.arange(K)
    by_start = np.full(lab.max() + 1, -1)
    by_start[a] = idx
    by_stop = np.full(lab.max() + 1, -1)
    by_stop[b] = idx
    prv = by_stop[a]
    nxt = by_start[b]
    # closed curves have no head: cut each at its segment of least start point
    live = nxt >= 0
    g = coo_matrix((np.ones(live.sum()), (idx[live], nxt[live])), shape=(K, K))
    ncomp, comp = connected_components(g, directed=False)
    is_open = np.zeros(ncomp, bool)
    is_open[comp[prv < 0]] = True
    cand = _lex_order(start, tol)
    cand = cand[~is_open[comp[cand]]]
    _, firsts = np.unique(comp[cand], return_index=True)
    prv[cand[firsts]] = -1
    d, head = _list_rank(prv, idx)
    heads, cid = np.unique(head, return_inverse=True)
    n = np.bincount(cid)
    by_pos = np.lexsort((d, cid))
    tails = by_pos[np.r_[np.nonzero(np.diff(cid[by_pos]))[0], K - 1]]       # last segment of each curve
    ends = np.stack([start[heads], stop[tails]])                             # (2, nc, 2)
    rank = _lex_order(ends.reshape(-1, 2), tol).argsort().reshape(2, -1)
    flip = is_open[comp[heads]] & (rank[1] < rank[0])                       # open, last end first
    d = np.where(flip[cid], n[cid] - 1 - d, d)
    first_pt = np.where(flip[:, None], ends[1], ends[0])
    number = np.empty(len(heads), np.int64)
    number[_lex_order(first_pt, tol)] = np.arange(len(heads))
    return number[cid], d, flip[cid]


def _lex_order(p: FloatArray, tol: float) -> IntArray:
    """Indices sorting points ``p (m, 2)`` by x (to ``tol``), then y."""
    return np.lexsort((p[:, 1], np.round(p[:, 0] / tol)))


def _list_rank(prv: IntArray, idx: IntArray) -> tuple[IntArray, IntArray]:
    """Distance of every list element to its head, and the head (pointer jumping:
    log K vectorised steps).  ``prv``: predecessor, -1 at heads."""
    p = np.where(prv >= 0, prv, idx)
    d = (prv >= 0).astype(np.int64)            # heads: 0, and they point to themselves
    while True:
        pp = p[p]
        if np.array_equal(pp, p):
            return d, p
        d = d + d[p]
        p = pp


def dense_curves(el: Element, seg: dict[str, NDArray[Any]], curve: IntArray, s0: FloatArray, rev: BoolArray,
                 n: int = DENSE) -> list[dict[str, FloatArray]]:
    """Dense polylines ``{"x", "y", "s"}`` (m) of every curve, segments in curve order;
    ``rev (K,)``: the segment is walked P1 -> P2 (else P2 -> P1)."""
    t = np.where(rev[:, None], -1.0, 1.0) * np.linspace(1.0, -1.0, n)[None, :]   # (K, n) walk order
    X = el.map_points(seg["xc"], seg["nodes"])           # the physical quadratic curve (cut.segment_curve)
    x = np.einsum("kpa,kai->kpi", Seg3.shape(t), X)
    # arc length of each sub-interval (4-point Gauss-Legendre), scaled to the segment length
    g, wg = np.polynomial.legendre.leggauss(4)
    ta, tb = t[:, :-1], t[:, 1:]
    tq = 0.5 * (ta + tb)[..., None] + 0.5 * (tb - ta)[..., None] * g                # (K, n-1, 4)
    speed = np.linalg.norm(np.einsum("kpqa,kai->kpqi", Seg3.dshape(tq), X), axis=-1)
    sub = np.einsum("kpq,q->kp", speed, wg) * 0.5 * np.abs(tb - ta)
    sub *= (seg["length"] / np.maximum(sub.sum(axis=1), 1e-300))[:, None]
    s = s0[:, None] + np.c_[np.zeros(len(sub)), np.cumsum(sub, axis=1)]
    out = []
    for c in np.unique(curve):
        rows = np.nonzero(curve == c)[0]
        keep = np.ones((len(rows), n), bool)
        keep[1:, 0] = False                                                   # shared end points
        out.append({"x": x[rows, :, 0][keep], "y": x[rows, :, 1][keep], "s": s[rows][keep]})
    return out


def add_reference(table: InterfaceTable, reference: References | None) -> None:
    """``<field>_ref`` and ``<field>_err`` columns for the fields with a formula."""
    for f in REFERENCE_FIELDS:
        formula = reference.get(f) if reference else None
        if formula is None:
            continue
        try:
            ref = _evaluate(formula, table.columns["x"], table.columns["y"])
            dense = [_evaluate(formula, c["x"], c["y"]) for c in table.curves]
        except Exception as exc:           # a formula invalid somewhere on the interface
            table.warnings.append(f"reference.{f}: not evaluated on the interface ({exc})")
            continue
        table.columns[f + "_ref"] = ref
        table.columns[f + "_err"] = table.columns[f] - ref
        for c, d in zip(table.curves, dense):
            c[f + "_ref"] = d


def _evaluate(formula: Formula | TimeFormula, x: FloatArray, y: FloatArray) -> FloatArray:
    return np.broadcast_to(np.asarray(formula(x=x, y=y), dtype=float), np.shape(x)).copy()


# -- file ---------------------------------------------------------------------------
def write(folder: Folder, table: InterfaceTable, name: str = "interface.csv") -> list[str]:
    """Write ``table`` (rank 0); returns ``[name]``."""
    cols = list(table.columns)
    data = np.column_stack([np.asarray(table.columns[c], dtype=float) for c in cols])
    fmt = ["%d" if c in INTEGER_COLUMNS else "%.17g" for c in cols]
    np.savetxt(folder.file(name), data, fmt=fmt, delimiter=",", header=",".join(cols), comments="")
    return [name]


def read(path: str | os.PathLike[str]) -> dict[str, NDArray[Any]]:
    """The columns of an interface.csv: {name: array} (integer columns as int)."""
    with open(path, encoding="utf-8") as f:
        names = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {n: (data[:, i].astype(np.int64) if n in INTEGER_COLUMNS else data[:, i])
            for i, n in enumerate(names)}
