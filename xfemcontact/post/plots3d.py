"""The PNG plots of a 3-D run (matplotlib, Agg), from the post mesh and its interface surface.

* ``plot_interface.png``: the interface surface seen from two opposite sides, coloured by
  LAGS_C and by the contact / friction status (laws without multipliers: by the gap and
  the slip);
* ``plot_profiles.png``: LAGS_C, LAGS_F1, gap and slip along the cuts of the interface by
  one or two planes (:func:`profile_planes`), with the ``[reference]`` formulas;
* ``plot_deformed.png``: the deformed body cut in half through its centre along the input
  cells' faces nearest the plane y = y_mid (the cells below removed) seen from that side,
  coloured by SIZZ per cell and sub-cell, the interface's trace in the cut drawn.

As in 2-D, each figure is drawn by a ``draw_*`` function from a dict of plain arrays that a
``*_data`` function reduced the meshes to (:mod:`xfemcontact.post.view3d`: at most the
polygons or pixels a picture shows), so that the plots can be drawn by the helper process
(:mod:`xfemcontact.output.plotter`).  Jobs name the functions ``plots3d.<name>``.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

import numpy as np

from xfemcontact.post import view3d
from xfemcontact.post.drawing import colour_limits, figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from numpy.typing import NDArray

    from xfemcontact.post.postmesh import PostMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    #: a job: (png name, function name, its arguments), see xfemcontact.post.plots
    Job = tuple[str, str, tuple[Any, ...]]

#: the two views of the interface: (elevation, azimuth) in degrees, from opposite sides
VIEWS = ((30.0, -60.0), (-30.0, 120.0))
#: the view of the cut body: from the y < y_mid side that was removed
CUT_VIEW = (25.0, -60.0)
#: the four linear triangles of a TRIA6 (nodes 0, 1, 2, then the mid-nodes 01, 12, 20)
TRIA6_SPLIT = np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]])
#: above this many facets each is drawn as the triangle of its vertices, not split in four
SPLIT_FACETS = 20000
#: the corner faces of the post mesh's cells in meshio's (VTK's) node order
CORNERS = {"hexahedron20": 8, "tetra10": 4}
CORNER_FACES = {"hexahedron20": np.array([[0, 1, 2, 3], [4, 5, 6, 7], [0, 1, 5, 4],
                                          [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]),
                "tetra10": np.array([[0, 1, 2], [0, 1, 3], [1, 2, 3], [0, 2, 3]])}
DEFORMATION = 0.05          # largest displayed displacement / body size
UNITS = {"LAGS_C": "Pa", "LAGS_F1": "-", "LAGS_F2": "-", "T": "Pa", "gap": "m", "slip": "m", "SIZZ": "Pa"}
STATUS_NAMES = ("open", "stick", "slip")
#: a coordinate axis is the interface's main normal direction if its mean |n_i| is within
#: this fraction of the largest (z first, then y, then x among such)
AXIS_TIE = 0.05
#: at most this many points per profile curve are kept (evenly in arc length)
PROFILE_POINTS = 2000


def _triangles(surface: PostMesh, split: bool = True) -> IntArray:
    """Linear triangles ``(t, 3)`` of the TRIA6 facets of ``surface``: four per facet, or one
    (the vertices) without ``split`` or above :data:`SPLIT_FACETS` facets."""
    conn = surface.blocks[0][1] if surface.blocks else np.zeros((0, 6), np.int64)
    pieces = TRIA6_SPLIT if split and len(conn) <= SPLIT_FACETS else np.array([[0, 1, 2]])
    return conn[:, pieces].reshape(-1, 3)


# -- (a) the interface surface ------------------------------------------------------------
def interface_fields(surface: PostMesh, multipliers: bool) -> list[tuple[str, FloatArray]]:
    """The fields drawn on the interface, ``[(name, node values)]``: LAGS_C and the status
    (0 open, 1 stick, 2 slip) with multipliers, else the gap and the slip."""
    pd = surface.point_data
    if multipliers:
        return [("LAGS_C", pd["LAGS_C"]), ("status", pd["contact"] * (1.0 + pd["sliding"]))]
    return [("gap", pd["gap"]), ("slip", pd["slip"])]


def interface_data(surface: PostMesh, multipliers: bool) -> dict[str, Any]:
    """What :func:`draw_interface` draws: per field, its range and a picture per view."""
    tri = _triangles(surface)
    out: dict[str, Any] = {"views": VIEWS, "fields": [], "facets": len(surface.blocks[0][1])}
    geometry = [view3d.layout(surface.points, tri, view3d.view(*ev), edges=False) for ev in VIEWS]
    for name, v in interface_fields(surface, multipliers):
        values = v[tri].mean(axis=1)
        out["fields"].append({"name": name, "range": (float(v.min()), float(v.max())) if len(v) else (0.0, 0.0),
                              "pictures": [view3d.paint(g, values) for g in geometry]})
    return out


def draw_interface(d: dict[str, Any], title: str) -> Figure:
    """The figure of :func:`interface_data`'s ``d``: a row per field, a column per view."""
    import matplotlib.colors as mcolors
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable

    rows = d["fields"]
    fig = figure(11, 4.6 * len(rows) + 0.8, left=0.02, right=0.9, bottom=0.04, top=0.88, wspace=0.05,
                  hspace=0.15)
    axes = fig.subplots(len(rows), len(d["views"]), squeeze=False)
    for r, field in enumerate(rows):
        if field["name"] == "status":
            cmap = mcolors.ListedColormap(["0.8", "tab:blue", "tab:red"])
            norm = mcolors.BoundaryNorm([-0.5, 0.5, 1.5, 2.5], 3)
        else:
            cmap = colormaps["viridis"]
            lo, hi = field["range"]
            norm = mcolors.Normalize(*colour_limits([lo, hi]))
        for c, (pic, (elev, azim)) in enumerate(zip(field["pictures"], d["views"])):
            ax = axes[r, c]
            view3d.draw(ax, pic, cmap, norm)
            view3d.triad(ax, view3d.view(elev, azim))
            ax.set_title(f"{field['name']}, seen from elevation {elev:g}, azimuth {azim:g} degrees", fontsize=9)
        cb = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=list(axes[r]), shrink=0.85)
        if field["name"] == "status":
            cb.set_ticks([0, 1, 2], labels=list(STATUS_NAMES))
        else:
            lo, hi = field["range"]
            cb.set_label(f"{field['name']} ({UNITS[field['name']]}), min {lo:.6g}, max {hi:.6g}")
            cb.formatter.set_useOffset(False)
            cb.update_ticks()
    fig.suptitle(f"{title}\ninterface surface ({d['facets']} curved facets), both sides")
    return fig


# -- (b) profiles ------------------------------------------------------------------------------
def profile_planes(surface: PostMesh, point: Sequence[float] | None = None,
                   normal: Sequence[float] | None = None) -> list[tuple[FloatArray, FloatArray, FloatArray]]:
    """The planes cutting the interface for the profiles, ``[(point, unit normal, unit
    direction along the cut)]``.

    ``point`` defaults to the interface's centre (the area-weighted mean of its
    triangles' centres).  With ``normal``, that one plane, walked along the coordinate
    axis least aligned with the normal (projected on the plane).  Otherwise two: the
    coordinate planes through the point that contain the interface's main normal axis
    (the axis of largest area-weighted mean |n_i|, z first, then y, then x among those
    within :data:`AXIS_TIE`), walked along the third axis: for a horizontal interface
    the lines along x and along y; for a sphere the meridians in the x-z and y-z planes.
    """
    X = surface.points
    tri = _triangles(surface)
    a = 0.5 * np.linalg.norm(np.cross(X[tri[:, 1]] - X[tri[:, 0]], X[tri[:, 2]] - X[tri[:, 0]]), axis=1)
    area = max(float(a.sum()), 1e-300)
    centre = (a[:, None] * X[tri].mean(axis=1)).sum(axis=0) / area
    p = centre if point is None else np.asarray(point, float)
    eye = np.eye(3)
    if normal is not None:
        m = np.asarray(normal, float) / np.linalg.norm(normal)
        j = int(np.argmin(np.abs(m) + 1e-12 * np.arange(3)))
        e = eye[j] - m[j] * m
        return [(p, m, e / np.linalg.norm(e))]
    n = surface.point_data["normal"][tri].mean(axis=1)
    mean_abs = (a[:, None] * np.abs(n)).sum(axis=0) / area
    k = max(i for i in range(3) if mean_abs[i] >= (1 - AXIS_TIE) * mean_abs.max())
    others = [i for i in range(3) if i != k]
    return [(p, eye[i], eye[j]) for i, j in (others, others[::-1])]


def _cut(X: FloatArray, tri: IntArray, normals: FloatArray, p: FloatArray, m: FloatArray
         ) -> tuple[IntArray, FloatArray, IntArray, FloatArray]:
    """The segments where the plane (p, m) cuts the triangles ``tri`` of ``X``: per segment
    its two edge crossings, each given by the edge's node ids ``(K, 2, 2)`` (least first)
    and the weight of the second node ``(K, 2)``; oriented so that the cut runs along
    ``m x n`` (n the interface normal), and the triangle of each segment."""
    dist = (X - p) @ m
    up = dist[tri] >= 0                                              # (t, 3)
    cut = np.nonzero(up.any(axis=1) & ~up.all(axis=1))[0]
    ends = np.zeros((len(cut), 2, 2), np.int64)
    wts = np.zeros((len(cut), 2))
    filled = np.zeros(len(cut), np.int64)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        a, b = tri[cut, i], tri[cut, j]
        on = up[cut, i] != up[cut, j]
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        t = dist[lo] / np.where(on, dist[lo] - dist[hi], 1.0)
        rows = np.nonzero(on)[0]
        ends[rows, filled[rows]] = np.c_[lo, hi][rows]
        wts[rows, filled[rows]] = t[rows]
        filled[rows] += 1
    P = _at(X, ends, wts)
    length = np.linalg.norm(P[:, 1] - P[:, 0], axis=1)
    keep = length > 1e-12 * (float(np.ptp(X, axis=0).max()) if len(X) else 1.0)   # not a vertex on the plane
    ends, wts, cut, P = ends[keep], wts[keep], cut[keep], P[keep]
    n = normals[tri[cut]].mean(axis=1)
    flip = np.einsum("ki,ki->k", P[:, 1] - P[:, 0], np.cross(m, n)) < 0
    ends[flip], wts[flip], P[flip] = ends[flip][:, ::-1], wts[flip][:, ::-1], P[flip][:, ::-1]
    return ends, wts, cut, P


def _at(values: NDArray[Any], ends: IntArray, wts: FloatArray) -> NDArray[Any]:
    """Values at edge crossings: ``(1 - w) v[a] + w v[b]`` for ``ends (..., 2)``, ``wts (...)``."""
    w = wts.reshape(wts.shape + (1,) * (values.ndim - 1))
    return (1.0 - w) * values[ends[..., 0]] + w * values[ends[..., 1]]


def profile_data(surface: PostMesh, planes: Sequence[tuple[FloatArray, FloatArray, FloatArray]],
                 fields: Sequence[str], references: Mapping[str, Callable[..., Any]] | None = None
                 ) -> list[dict[str, Any]]:
    """The profiles of ``fields`` along the cuts of the interface by ``planes``
    (:func:`profile_planes`): per plane ``{"point", "normal", "direction", "curves"}``, each
    curve a dict of arrays along it: ``s`` (m, the arc length from its start), x, y, z, the
    fields and ``<field>_ref`` for those with a ``references`` formula of x, y, z.  The
    curves are chained from the cut segments (:func:`xfemcontact.output.interface_csv.chain`,
    in the plane's coordinates); an open curve starts at its end of least coordinate along
    the plane's direction.  The facets are cut as the triangles of their vertices, which
    neighbouring facets share (their curved edges, whose mid-nodes two cells place each in
    its own reference coordinates, need not be the same curve): the cut is a polyline
    through the interface points on the facets' edges, with the values there.  Where
    facets of two cells do not share their vertices (a face that the two cells split along
    different diagonals) the curve is drawn in pieces."""
    from xfemcontact.output.interface_csv import chain

    X, pd = surface.points, surface.point_data
    tri = _triangles(surface, split=False)
    out = []
    for p, m, e in planes:
        ends, wts, _, P = _cut(X, tri, pd["normal"], p, m)
        b = np.cross(m, e)
        plane = np.stack([(P - p) @ e, (P - p) @ b], axis=-1)                  # (K, 2, 2)
        curve, pos, rev = chain(plane[:, 0], plane[:, 1]) if len(P) else (np.zeros(0, int),) * 3
        values = {f: _at(pd[f], ends, wts) for f in fields}
        curves = []
        for c in np.unique(curve):
            rows = np.nonzero(curve == c)[0]
            rows = rows[np.argsort(pos[rows])]
            walk = np.where(rev[rows, None], [1, 0], [0, 1])                   # (r, 2) end order
            pts = np.take_along_axis(P[rows], walk[..., None], axis=1).reshape(-1, 3)
            keep = np.r_[True, np.ones(len(pts) - 1, bool)]
            keep[2::2] = False                                                 # shared ends, once
            pts = pts[keep]
            s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
            cd: dict[str, FloatArray] = {"s": s, "x": pts[:, 0], "y": pts[:, 1], "z": pts[:, 2]}
            for f in fields:
                cd[f] = np.take_along_axis(values[f][rows], walk, axis=1).reshape(-1)[keep]
            curves.append(_thin(_with_references(cd, fields, references)))
        out.append({"point": p, "normal": m, "direction": e, "curves": curves})
    return out


def _with_references(cd: dict[str, FloatArray], fields: Sequence[str],
                     references: Mapping[str, Callable[..., Any]] | None) -> dict[str, FloatArray]:
    """``cd`` with ``<field>_ref`` for the fields with a reference formula (those that cannot
    be evaluated along the curve are left out)."""
    for f in fields:
        formula = references.get(f) if references else None
        if formula is None:
            continue
        try:
            cd[f + "_ref"] = np.broadcast_to(np.asarray(formula(x=cd["x"], y=cd["y"], z=cd["z"]), float),
                                             cd["s"].shape).copy()
        except Exception:                     # a formula invalid somewhere on the curve
            continue
    return cd


def _thin(cd: dict[str, FloatArray]) -> dict[str, FloatArray]:
    """At most :data:`PROFILE_POINTS` points, evenly spread in arc length (a plot shows
    no more)."""
    n = len(cd["s"])
    if n <= PROFILE_POINTS:
        return cd
    keep = np.unique(np.linspace(0, n - 1, PROFILE_POINTS).round().astype(np.int64))
    return {k: v[keep] for k, v in cd.items()}


def _plane_name(m: FloatArray, p: FloatArray, e: FloatArray) -> str:
    axis = int(np.argmax(np.abs(m)))
    if abs(abs(m[axis]) - 1.0) < 1e-12:
        return f"{'xyz'[axis]} = {p[axis]:.4g}, along {'xyz'[int(np.argmax(np.abs(e)))]}"
    return (f"plane through ({p[0]:.4g}, {p[1]:.4g}, {p[2]:.4g}), normal "
            f"({m[0]:.3g}, {m[1]:.3g}, {m[2]:.3g})")


def profiles_figure(profiles: Sequence[Mapping[str, Any]], fields: Sequence[str], title: str,
                    jump_scale: float = 0.0) -> Figure:
    """The profiles of :func:`profile_data`: a column per plane, a row per field; the
    computed values as a line with markers, the reference (if any) as a grey line.  Each
    axis spans at least 1e-3 of the field's largest magnitude (of ``jump_scale``, m, a
    typical displacement, for the gap and the slip), so that round-off shows as flat."""
    fig = figure(6.0 * len(profiles) + 1.0, 2.3 * len(fields) + 1.2, left=0.1 if len(profiles) > 1 else 0.14,
                  right=0.98, bottom=0.07, top=0.88, wspace=0.25, hspace=0.3)
    axes = fig.subplots(len(fields), len(profiles), squeeze=False, sharex="col")
    for c, prof in enumerate(profiles):
        for r, f in enumerate(fields):
            ax = axes[r, c]
            many = len(prof["curves"]) > 1
            for k, cd in enumerate(prof["curves"]):
                tag = f" ({len(prof['curves'])} curves)" if many else ""
                if f + "_ref" in cd:
                    ax.plot(cd["s"], cd[f + "_ref"], "-", color="0.45", lw=1.6,
                            label=f"{f} reference" if k == 0 else None)
                ax.plot(cd["s"], cd[f], ".-", ms=2.5, lw=0.8, color=f"C{k % 10}",
                        label=f"{f} computed{tag}" if k == 0 else None)
            ax.set_ylabel(f"{f} ({UNITS[f]})")
            ax.grid(alpha=0.3)
            seen = [cd[k] for cd in prof["curves"] for k in (f, f + "_ref") if k in cd and len(cd[k])]
            if seen:
                v = np.concatenate(seen)
                scale = jump_scale if f in ("gap", "slip") else float(np.abs(v).max())
                lo, hi = colour_limits(v, scale)
                pad = 0.05 * (hi - lo)
                ax.set_ylim(lo - pad, hi + pad)
            ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 4), useOffset=False)
            if prof["curves"]:
                ax.legend(fontsize=7, loc="best")
            if r == 0:
                ax.set_title(_plane_name(prof["normal"], prof["point"], prof["direction"]), fontsize=9)
        axes[-1, c].set_xlabel("s, arc length along the cut (m)")
        if not prof["curves"]:
            axes[0, c].text(0.5, 0.5, "the plane does not cut the interface", transform=axes[0, c].transAxes,
                            ha="center")
    fig.suptitle(f"{title}\ninterface fields along cuts through the interface")
    return fig


# -- (c) the deformed body, cut in half ---------------------------------------------------
def _faces(blocks: Sequence[tuple[str, IntArray]], cells: Sequence[IntArray]) -> list[tuple[IntArray, IntArray]]:
    """Corner faces of the chosen cells of each block: ``[(faces (f, c), cell index (f,))]``
    per face size c (the cell index counts over all blocks)."""
    by_size: dict[int, list[tuple[IntArray, IntArray]]] = {}
    start = 0
    for (t, conn), rows in zip(blocks, cells):
        local = CORNER_FACES[t]
        f = conn[rows][:, local].reshape(-1, local.shape[1])
        by_size.setdefault(local.shape[1], []).append((f, np.repeat(start + rows, len(local))))
        start += len(conn)
    return [(np.concatenate([a for a, _ in v]), np.concatenate([b for _, b in v])) for v in by_size.values()]


def _unpaired(faces: IntArray) -> IntArray:
    """Rows of ``faces (f, c)`` whose vertex set appears once (the boundary of the cells)."""
    from xfemcontact.mesh.plex3d import row_keys

    key = row_keys(faces)
    return np.nonzero(np.bincount(key)[key] == 1)[0]


def cutaway_data(points: FloatArray, blocks: Sequence[tuple[str, IntArray]], point_data: Mapping[str, NDArray[Any]],
                 cell_data: Mapping[str, Sequence[NDArray[Any]]], field: str = "SIZZ",
                 stress_scale: float = 0.0) -> dict[str, Any]:
    """What :func:`draw_cutaway` draws: the cells of the post mesh whose input cell lies at
    y_mid (the middle of the body's extent in y) or above (:func:`_kept_half`), displaced (the largest displacement
    :data:`DEFORMATION` of the body's size), their boundary faces seen from :data:`CUT_VIEW`
    and coloured by the cell field ``field``, and the interface's trace in the cut (the
    edges of the cut's faces between interface points, NFISSU != 0)."""
    u = np.stack([point_data[c] for c in ("DX", "DY", "DZ")], axis=1)
    size = float(np.ptp(points, axis=0).max()) if len(points) else 1.0
    umax = float(np.linalg.norm(u, axis=1).max()) if len(u) else 0.0
    scale = DEFORMATION * size / umax if umax > 0 else 0.0
    xd = points + scale * u
    y_mid = 0.5 * (points[:, 1].min() + points[:, 1].max()) if len(points) else 0.0
    keep = _kept_half(points, blocks, cell_data.get("cell"), y_mid)
    y_cut = min((float(points[conn[rows, :CORNERS[t]], 1].min()) for (t, conn), rows in zip(blocks, keep)
                 if len(rows)), default=y_mid)
    values = np.concatenate(list(cell_data[field]))
    polys, vals, trace = [], [], []
    nf = point_data.get("NFISSU")
    every = [np.arange(len(conn)) for _, conn in blocks]
    for (faces, cell), (all_faces, _) in zip(_faces(blocks, keep), _faces(blocks, every)):
        outer = _unpaired(faces)
        polys.append(faces[outer])
        vals.append(values[cell[outer]])
        if nf is not None:                    # the cut: faces of kept cells paired in the whole mesh
            cut = np.setdiff1d(outer, _match(faces[outer], all_faces[_unpaired(all_faces)], outer))
            ring = np.c_[faces[cut], faces[cut][:, :1]]
            e = np.stack([ring[:, :-1], ring[:, 1:]], axis=-1).reshape(-1, 2)
            trace.append(xd[e[(nf[e] != 0).all(axis=1)]])
    R = view3d.view(*CUT_VIEW)
    faces, fvals = _one_kind(polys, vals)
    merged = view3d.picture(xd, faces, fvals, R, edges=len(fvals) < 1500)
    lines = np.concatenate(trace) if trace else np.zeros((0, 2, 3))
    return {"picture": merged, "trace": view3d.project(lines.reshape(-1, 3), R)[0].reshape(-1, 2, 2),
            "field": field, "scale": scale, "umax": umax, "y_cut": y_cut,
            "clim": colour_limits(values, stress_scale) if len(values) else (0.0, 1.0),
            "range": (float(values.min()), float(values.max())) if len(values) else (0.0, 0.0)}


def _kept_half(points: FloatArray, blocks: Sequence[tuple[str, IntArray]], parent: Sequence[IntArray] | None,
               y_mid: float) -> list[IntArray]:
    """Per block, the cells kept in the cut-away view: those whose input cell (``parent``,
    the cell field ``cell``: the sub-cells of a cut cell go together, so the cut follows the
    input cells' faces) has the middle of its extent in y at y_mid or above."""
    lo_y = [points[conn[:, :CORNERS[t]], 1].min(axis=1) for t, conn in blocks]
    hi_y = [points[conn[:, :CORNERS[t]], 1].max(axis=1) for t, conn in blocks]
    if parent is None:
        return [np.nonzero(0.5 * (a + b) >= y_mid)[0] for a, b in zip(lo_y, hi_y)]
    ids = np.concatenate(list(parent)) if len(parent) else np.zeros(0, np.int64)
    n = int(ids.max()) + 1 if len(ids) else 0
    lo, hi = np.full(n, np.inf), np.full(n, -np.inf)
    np.minimum.at(lo, ids, np.concatenate(lo_y))
    np.maximum.at(hi, ids, np.concatenate(hi_y))
    upper = 0.5 * (lo + hi) >= y_mid
    return [np.nonzero(upper[np.asarray(c)])[0] for c in parent]


def _match(faces: IntArray, table: IntArray, rows: IntArray) -> IntArray:
    """The entries of ``rows`` whose face (``faces``, same order) is in ``table`` (vertex sets)."""
    from xfemcontact.mesh.plex3d import match_rows

    return rows[match_rows(np.sort(faces, axis=1), np.sort(table, axis=1)) >= 0]


def _one_kind(polys: list[IntArray], vals: list[FloatArray]) -> tuple[IntArray, FloatArray]:
    """Faces of one size from faces of several (triangles and quadrangles): the quadrangles
    split into two triangles when both kinds are there."""
    if len(polys) <= 1:
        return (polys[0], vals[0]) if polys else (np.zeros((0, 3), np.int64), np.zeros(0))
    tri, v = [], []
    for p, val in zip(polys, vals):
        if p.shape[1] == 4:
            tri += [p[:, [0, 1, 2]], p[:, [0, 2, 3]]]
            v += [val, val]
        else:
            tri.append(p)
            v.append(val)
    return np.concatenate(tri), np.concatenate(v)


def draw_cutaway(d: dict[str, Any], title: str) -> Figure:
    """The figure of :func:`cutaway_data`'s ``d``."""
    import matplotlib.colors as mcolors
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.collections import LineCollection

    fig = figure(8.5, 7.5, left=0.03, right=0.88, bottom=0.04, top=0.85)
    ax = fig.subplots()
    cmap, norm = colormaps["viridis"], mcolors.Normalize(*d["clim"])
    view3d.draw(ax, d["picture"], cmap, norm)
    if len(d["trace"]):
        ax.add_collection(LineCollection(d["trace"], colors="tab:red", linewidths=1.4,
                                         label="interface in the cut"))
        ax.legend(loc="upper right", fontsize=8)
    view3d.triad(ax, view3d.view(*CUT_VIEW))
    cb = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.8)
    lo, hi = d["range"]
    cb.set_label(f"{d['field']} ({UNITS.get(d['field'], '')}), mean per cell and sub-cell\nmin {lo:.7g}, max {hi:.7g}")
    cb.formatter.set_useOffset(False)
    cb.update_ticks()
    how = f"displacements x {d['scale']:.3g}" if d["scale"] > 0 else "no displacement"
    fig.suptitle(f"{title}\ndeformed body cut along the cells' faces at y = {d['y_cut']:.4g} (the part below "
                 f"removed),\n{how} (max |u| = {d['umax']:.3g} m), coloured by {d['field']}")
    return fig


# -- jobs --------------------------------------------------------------------------------
def jobs(title: str, post: PostMesh, multipliers: bool, stress_scale: float = 0.0,
         references: Mapping[str, Callable[..., Any]] | None = None, profile_point: Sequence[float] | None = None,
         profile_normal: Sequence[float] | None = None) -> list[Job]:
    """The 3-D plots of ``post`` (and its interface surface) as jobs (see
    :func:`xfemcontact.post.plots.run`), reduced to plain arrays here (on rank 0)."""
    out: list[Job] = []
    surface = post.interface
    if surface is not None and surface.blocks and len(surface.blocks[0][1]):
        out.append(("plot_interface.png", "plots3d.draw_interface", (interface_data(surface, multipliers), title)))
        fields = ("LAGS_C", "LAGS_F1", "gap", "slip") if multipliers else ("gap", "slip")
        planes = profile_planes(surface, profile_point, profile_normal)
        umax = float(np.linalg.norm(post.displacement(), axis=1).max()) if len(post.points) else 0.0
        out.append(("plot_profiles.png", "plots3d.profiles_figure",
                    (profile_data(surface, planes, fields, references), fields, title, umax)))
    out.append(("plot_deformed.png", "plots3d.draw_cutaway",
                (cutaway_data(post.points, post.blocks, post.point_data, post.cell_data,
                              stress_scale=stress_scale), title)))
    return out
