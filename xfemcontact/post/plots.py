"""PNG plots of a run (matplotlib, Agg; no pyplot state).

* ``plot_multipliers.png``: LAGS_C and LAGS_F1 along the interface abscissa s,
  computed values (markers, one per point and cell) against the ``[reference]``
  formula (line), with the error in a second column;
* ``plot_deformed.png``: the post-processing mesh deformed (displacements scaled
  so the largest is 5 % of the domain size) and coloured by SIYY per (sub-)cell,
  with both sides of the interface drawn;
* ``plot_status.png``: contact and friction statuses along s, with the gap and
  slip;
* ``plot_convergence.png`` (several Newton solves only): Newton residual norms of
  every solve of the contact / friction loops, and the threshold changes.

In 3-D (:mod:`xfemcontact.post.plots3d`): ``plot_interface.png`` (the interface
surface coloured by LAGS_C and the statuses), ``plot_profiles.png`` (the interface
fields along cuts by planes) and ``plot_deformed.png`` (the deformed body cut in half);
``plot_convergence.png`` as in 2-D.

Each ``*_figure`` function returns a :class:`matplotlib.figure.Figure` built from
plain arrays (the columns of interface.csv, the post mesh, results.json's
iteration record), so a plot can be redrawn from the files.
"""
from __future__ import annotations

import importlib
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping, Protocol, Sequence

import numpy as np

from xfemcontact.post.drawing import colour_limits as _colour_limits
from xfemcontact.post.drawing import figure as _figure
from xfemcontact.post.drawing import plain_log_labels
from xfemcontact.post.drawing import rasterise

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from numpy.typing import NDArray

    from xfemcontact.output.interface_csv import InterfaceTable
    from xfemcontact.post.postmesh import PostMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]
    #: columns of an interface table (interface.csv), or of a dense polyline, by name
    Columns = Mapping[str, NDArray[Any]]
    #: cell blocks of a post mesh: [(meshio cell type, connectivity (k, nn))]
    Blocks = Sequence[tuple[str, IntArray]]


#: a plot to draw: (png name, name of a function of this module, its arguments)
Job = tuple[str, str, tuple[Any, ...]]


class Folder(Protocol):
    """Where the plots go (an :class:`xfemcontact.output.folder.OutputFolder`)."""

    def file(self, name: str) -> Path: ...


#: polygon node order of each cell type (vertices and mid-edge nodes around the boundary)
OUTLINE = {"quad8": [0, 4, 1, 5, 2, 6, 3, 7], "triangle6": [0, 3, 1, 4, 2, 5]}
EDGES = {"quad8": [(0, 4, 1), (1, 5, 2), (2, 6, 3), (3, 7, 0)],
         "triangle6": [(0, 3, 1), (1, 4, 2), (2, 5, 0)]}
DEFORMATION = 0.05          # largest displayed displacement / domain size
FIELD_UNITS = {"LAGS_C": "Pa", "LAGS_F1": "-", "gap": "m", "slip": "m", "SIYY": "Pa"}
SIDE_STYLE = {-1: dict(color="tab:red", lw=1.6, ls="-", label="interface, LN < 0 side"),
              1: dict(color="black", lw=1.0, ls="--", label="interface, LN > 0 side")}


def _curves(cols: Columns) -> list[IntArray]:
    """Row indices of each curve of an interface table."""
    return [np.nonzero(cols["curve"] == c)[0] for c in np.unique(cols["curve"])]


# -- (a) multipliers along s ---------------------------------------------------------
def multipliers_figure(cols: Columns, title: str, curves: Sequence[Columns] | None = None,
                       fields: Sequence[str] = ("LAGS_C", "LAGS_F1")) -> Figure:
    """LAGS_C, LAGS_F1 against s.

    ``cols``: interface.csv columns (``s``, the fields, optional
    ``<field>_ref``/``_err``); ``curves``: optional dense polylines with
    ``s`` and ``<field>_ref`` for smooth reference lines.  Lines carry labels
    ``"<field> computed"``, ``"<field> reference"``, ``"<field> error"``.
    """
    has_ref = any(f + "_ref" in cols for f in fields)
    fig = _figure(12 if has_ref else 7.5, 6.5, left=0.08 if has_ref else 0.11, right=0.985, bottom=0.08,
                  top=0.86, wspace=0.2, hspace=0.22)
    axes = fig.subplots(len(fields), 2 if has_ref else 1, sharex=True, squeeze=False)
    rows = _curves(cols)
    for i, f in enumerate(fields):
        ax = axes[i, 0]
        unit = FIELD_UNITS[f]
        for k, r in enumerate(rows):
            tag = f" (curve {k})" if len(rows) > 1 else ""
            if f + "_ref" in cols:
                if curves is not None and f + "_ref" in curves[k]:
                    ax.plot(curves[k]["s"], curves[k][f + "_ref"], "-", color="0.35", lw=1.5,
                            label=f"{f} reference{tag}")
                else:
                    ax.plot(cols["s"][r], cols[f + "_ref"][r], "-", color="0.35", lw=1.5,
                            label=f"{f} reference{tag}")
            ax.plot(cols["s"][r], cols[f][r], "o", ms=4, mfc="none", color=f"C{k}",
                    label=f"{f} computed{tag}")
            if not has_ref:
                ax.plot(cols["s"][r], cols[f][r], "-", lw=0.6, alpha=0.5, color=f"C{k}")
        ax.set_ylabel(f"{f} ({unit})")
        ax.set_title(f"{f} along the interface")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
        if has_ref:
            ex = axes[i, 1]
            if f + "_err" in cols:
                emax = float(np.abs(cols[f + "_err"]).max()) if len(cols[f + "_err"]) else 0.0
                for k, r in enumerate(rows):
                    ex.plot(cols["s"][r], cols[f + "_err"][r], ".-", ms=4, lw=0.8, color=f"C{k}",
                            label=f"{f} error" + (f" (curve {k})" if len(rows) > 1 else "")
                            + f", max |error| {emax:.3g}" + (f" {unit}" if unit != "-" else ""))
                ex.set_title(f"{f} error = computed - reference")
                ex.axhline(0.0, color="0.5", lw=0.8)
                ex.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
                ex.legend(loc="best", fontsize=8)
            else:
                ex.set_title(f"no reference for {f}")
            ex.set_ylabel(f"{f} error ({unit})")
            ex.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("s, curvilinear abscissa along the interface (m)")
    fig.suptitle(f"{title}\ninterface multipliers: computed (markers)"
                 + (" and reference (line)" if has_ref else ""))
    return fig


# -- (b) deformed mesh ------------------------------------------------------------------
#: up to this many cells the deformed mesh is drawn as polygons with their edges; above
#: it, as an image of the cells (a picture of this size shows no more than that)
VECTOR_CELLS = 6000
#: long side of that image, pixels (about the size of the axes in the figure)
RASTER_PIXELS = 800
#: mesh lines are drawn on the image where cells are at least this many pixels wide
RASTER_LINE_PIXELS = 5.0
#: triangles of each cell type drawn into the image: curved sides followed through
#: their mid-nodes (the 4 triangles of a 6-node triangle, 6 for a QUAD8) when cells
#: are wide enough for their mesh lines to be drawn or are sub-cells (curved along
#: the interface); straight between vertices otherwise (a pixel or two per cell)
RASTER_TRIANGLES = {("triangle6", True): [(0, 3, 5), (3, 1, 4), (5, 4, 2), (3, 4, 5)],
                    ("quad8", True): [(0, 4, 7), (4, 1, 5), (5, 2, 6), (6, 3, 7), (4, 5, 6), (4, 6, 7)],
                    ("triangle6", False): [(0, 1, 2)],
                    ("quad8", False): [(0, 1, 2), (0, 2, 3)]}


def deformed_figure(points: FloatArray, blocks: Blocks, point_data: Mapping[str, NDArray[Any]],
                    cell_data: Mapping[str, Sequence[NDArray[Any]]], title: str, field: str = "SIYY",
                    stress_scale: float = 0.0) -> Figure:
    """The deformed post mesh coloured by the cell field ``field``.

    ``points (np, 2)`` m; ``blocks`` [(meshio type, conn)]; ``point_data`` with
    DX, DY (m) and NFISSU; ``cell_data`` {name: [per block]}; ``stress_scale``
    (Pa, e.g. E max|u| / size): the colour range spans at least 1e-3 of it.

    Up to :data:`VECTOR_CELLS` cells the cells are polygons with their edges;
    beyond, the cells are drawn into an image of :data:`RASTER_PIXELS` (every
    pixel the colour of the cell under its centre, mesh lines where cells are
    at least :data:`RASTER_LINE_PIXELS` wide): the same picture, drawn in a
    fraction of the time and memory of a million polygon vertices.
    """
    return draw_deformed(deformed_data(points, blocks, point_data, cell_data, field, stress_scale), title)


def deformed_data(points: FloatArray, blocks: Blocks, point_data: Mapping[str, NDArray[Any]],
                  cell_data: Mapping[str, Sequence[NDArray[Any]]], field: str = "SIYY",
                  stress_scale: float = 0.0) -> dict[str, Any]:
    """What :func:`draw_deformed` draws, reduced to what the picture shows (NumPy
    only): the cells as polygons (small meshes) or as an RGBA image, the interface
    lines of each side, the colour range and the titles' numbers."""
    u = np.c_[point_data["DX"], point_data["DY"]]
    size = float(np.max(_column_max(points) - _column_min(points))) if len(points) else 1.0
    umax = float(np.abs(np.hypot(u[:, 0], u[:, 1])).max()) if len(u) else 0.0
    scale = DEFORMATION * size / umax if umax > 0 else 0.0
    xd = points + scale * u
    values = np.concatenate(cell_data[field]) if field in cell_data else None
    ncells = sum(len(conn) for _, conn in blocks)
    d: dict[str, Any] = {"field": field, "scale": scale, "umax": umax, "how_drawn": "",
         "clim": _colour_limits(values, stress_scale) if values is not None and len(values) else None,
         "range": (float(values.min()), float(values.max())) if values is not None and len(values) else None}
    if ncells <= VECTOR_CELLS or values is None:
        d["polygons"] = [xd[conn[:, OUTLINE[t]]] for t, conn in blocks]       # per block (k, nodes, 2)
        d["values"] = values
    else:
        d["image"], d["lines"], d["extent"], d["how_drawn"] = _raster(xd, blocks, values, cell_data.get("subcell"))
    nf = point_data.get("NFISSU")
    d["interface"] = {}
    if nf is not None:
        for side in (-1, 1):
            segs = _interface_edges(blocks, nf, side, xd)
            if len(segs):
                d["interface"][side] = segs
        d["legend"] = bool((nf != 0).any())
    if len(xd):
        lo, hi = _column_min(xd), _column_max(xd)
        pad = 0.02 * max(float(np.max(hi - lo)), 1e-300)
        d["xlim"], d["ylim"] = (lo[0] - pad, hi[0] + pad), (lo[1] - pad, hi[1] + pad)
    return d


def draw_deformed(d: dict[str, Any], title: str) -> Figure:
    """The figure of :func:`deformed_data`'s ``d``."""
    import matplotlib.colors as mcolors
    from matplotlib.cm import ScalarMappable
    from matplotlib.collections import LineCollection, PolyCollection

    fig = _figure(8.5, 7.5, left=0.09, right=0.92, bottom=0.13, top=0.87)
    ax = fig.subplots()
    field = d["field"]
    mappable = None
    if "image" in d:
        mappable = ScalarMappable(norm=mcolors.Normalize(*d["clim"]), cmap="viridis")
        img = d["image"]
        rgba = mappable.to_rgba(np.nan_to_num(img, nan=d["clim"][0]))          # (H, W, 4) floats
        rgba[np.isnan(img), 3] = 0.0
        if d["lines"] is not None:                        # mesh lines: half-way to dark grey
            on = d["lines"]
            rgba[on, :3] = 0.5 * rgba[on, :3] + 0.125
            rgba[on, 3] = 1.0
        ax.imshow(rgba, origin="lower", interpolation="nearest", extent=d["extent"])
    else:
        pc = PolyCollection([p for block in d["polygons"] for p in block], edgecolors="0.25", linewidths=0.25)
        if d["values"] is not None:
            pc.set_array(d["values"])
            pc.set_cmap("viridis")
            pc.set_clim(*d["clim"])
            mappable = pc
        ax.add_collection(pc)
    for side, segs in d["interface"].items():
        ax.add_collection(LineCollection(segs, **SIDE_STYLE[side]))
    if d.get("legend"):
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=2, fontsize=9, frameon=False)
    if "xlim" in d:
        ax.set_xlim(*d["xlim"])
        ax.set_ylim(*d["ylim"])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if mappable is not None:
        cb = fig.colorbar(mappable, ax=ax, shrink=0.85)
        lo, hi = d["range"]
        cb.set_label(f"{field} ({FIELD_UNITS.get(field, '')}), mean per cell and sub-cell\n"
                     f"min {lo:.7g}, max {hi:.7g}")
        cb.formatter.set_useOffset(False)
        cb.update_ticks()
    scale, umax = d["scale"], d["umax"]
    how = f"displacements x {scale:.3g}" if scale > 0 else "no displacement"
    fig.suptitle(f"{title}\ndeformed mesh, {how} (max |u| = {umax:.3g} m), coloured by {field}{d['how_drawn']}")
    return fig


def _raster(xd: FloatArray, blocks: Blocks, values: FloatArray, subcell: Sequence[IntArray] | None = None
            ) -> tuple[NDArray[np.float32], BoolArray | None, tuple[float, float, float, float], str]:
    """The cells drawn into an image (large meshes), NumPy only: returns the image of
    the cell values ``(H, W)`` (float32, NaN outside the mesh), the pixels of the mesh
    lines ``(H, W)`` bool or None, the extent, and the title words.  ``subcell``: per
    block, the sub-cell index of each cell (-1 uncut), if known."""
    lo, hi = _column_min(xd), _column_max(xd)
    span = np.maximum(hi - lo, 1e-300)
    px = float(span.max()) / RASTER_PIXELS                      # pixel size, m
    W, H = (np.ceil(span / px).astype(int) + 1).tolist()
    ncells = sum(len(conn) for _, conn in blocks)
    cell_px = float(np.sqrt(W * H / max(ncells, 1)))            # mean cell width, pixels (bounding box)
    lines = cell_px >= RASTER_LINE_PIXELS
    tris: list[IntArray] = []
    cells: list[IntArray] = []
    start = 0
    for b, (t, conn) in enumerate(blocks):
        curved = np.ones(len(conn), bool) if lines else (
            subcell[b] >= 0 if subcell is not None else np.ones(len(conn), bool))
        index = np.arange(start, start + len(conn))
        for kind in (False, True):
            rows = np.nonzero(curved == kind)[0]
            if len(rows):
                local = np.asarray(RASTER_TRIANGLES[t, kind])
                tris.append(conn[rows][:, local].reshape(-1, 3))
                cells.append(np.repeat(index[rows], len(local)))
        start += len(conn)
    tri, cell = np.concatenate(tris), np.concatenate(cells)
    label = rasterise((xd[tri] - lo) / px, cell, W, H)
    img = np.full((H, W), np.nan, np.float32)
    inside = label >= 0
    img[inside] = values[label[inside]]
    mask = None
    if lines:
        edges = np.concatenate([conn[:, OUTLINE[t]][:, _ring(len(OUTLINE[t]))].reshape(-1, 2)
                                for t, conn in blocks])
        ex, ey = _segment_pixels((xd[edges] - lo) / px, W, H)
        mask = np.zeros((H, W), bool)
        mask[ey, ex] = True
    extent = (lo[0] - 0.5 * px, lo[0] + (W - 0.5) * px, lo[1] - 0.5 * px, lo[1] + (H - 0.5) * px)
    words = (f"\n{ncells} cells drawn as an image of {W} x {H} pixels"
             + ("" if lines else f" (cells of {cell_px:.1g} pixels: no mesh lines)"))
    return img, mask, extent, words


def _column_min(a: FloatArray) -> FloatArray:
    """Column minima of ``a (n, k)`` (numpy reduces short rows slowly along axis 0)."""
    return np.array([a[:, j].min() for j in range(a.shape[1])])


def _column_max(a: FloatArray) -> FloatArray:
    return np.array([a[:, j].max() for j in range(a.shape[1])])


def _ring(k: int) -> IntArray:
    """Index pairs (i, i + 1 mod k) around a polygon of ``k`` nodes, as an array ``(k, 2)``."""
    i = np.arange(k)
    return np.c_[i, (i + 1) % k]


def _segment_pixels(seg: FloatArray, W: int, H: int) -> tuple[IntArray, IntArray]:
    """Pixels ``(ix, iy)`` along segments ``seg (S, 2, 2)`` in pixel units, one sample
    per pixel of length."""
    d = seg[:, 1] - seg[:, 0]
    n = np.ceil(np.abs(d).max(axis=1)).astype(np.int64) + 1
    s = np.repeat(n, n)
    k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
    f = (k / np.maximum(s - 1, 1))[:, None]
    p = np.repeat(seg[:, 0], n, axis=0) + f * np.repeat(d, n, axis=0)
    ix = np.clip(np.rint(p[:, 0]).astype(np.int64), 0, W - 1)
    iy = np.clip(np.rint(p[:, 1]).astype(np.int64), 0, H - 1)
    return ix, iy


def _interface_edges(blocks: Blocks, nfissu: IntArray, side: int, xd: FloatArray) -> FloatArray:
    """Polylines (a, mid, b) of the cell edges lying on the interface, copies of ``side``."""
    out = []
    for t, conn in blocks:
        e = np.array(EDGES[t])
        nodes = conn[:, e]                                                    # (k, ne, 3)
        on = np.all(nfissu[nodes] == side, axis=2)
        out.append(xd[nodes[on]])
    return np.concatenate(out) if out else np.zeros((0, 3, 2))


# -- (c) statuses along s ---------------------------------------------------------------
def status_figure(cols: Columns, title: str, jump_scale: float = 0.0, friction: bool = True) -> Figure:
    """Contact and sliding statuses along s (steps), with the gap and slip (twin axes).

    ``jump_scale`` (m): the gap and slip axes span at least +-1e-3 of it (a
    typical displacement), so round-off jumps show as zero, not as noise.
    The friction state is -1 where the point is open (no friction), else
    0 stick / 1 slip.
    """
    fig = _figure(10, 6.5, left=0.08, right=0.91, bottom=0.08, top=0.86, hspace=0.25)
    axes = fig.subplots(2, 1, sharex=True)
    rows = _curves(cols)
    contact = np.asarray(cols["contact"])
    state = {"contact": contact, "friction": np.where(contact > 0, cols["sliding"], -1)}
    spec = (("contact", "gap", {0: "open", 1: "contact"}),
            ("friction", "slip", {-1: "open", 0: "stick", 1: "slip"}))
    for ax, (status, jump, names) in zip(axes, spec):
        tw = ax.twinx()
        for k, r in enumerate(rows):
            tag = f" (curve {k})" if len(rows) > 1 else ""
            ax.step(cols["s"][r], state[status][r], where="post", color=f"C{k}", lw=1.8,
                    label=f"{status} status{tag}")
            ax.plot(cols["s"][r], state[status][r], "o", ms=3, color=f"C{k}")
            tw.plot(cols["s"][r], cols[jump][r], "-", color="0.55", lw=1.0, label=f"{jump}{tag}")
        ax.set_yticks(list(names), list(names.values()))
        ax.set_ylim(min(names) - 0.15, max(names) + 0.15)
        tw.set_ylabel(f"{jump} (m)", color="0.4")
        jmax = float(np.abs(cols[jump]).max()) if len(cols[jump]) else 0.0
        floor = max(1e-3 * jump_scale, 1.05 * jmax)
        if floor > 0:
            lo, hi = tw.get_ylim()
            tw.set_ylim(min(lo, -floor), max(hi, floor))
        tw.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
        counts = ", ".join(f"{int(np.sum(state[status] == v))} {n}" for v, n in names.items())
        what = "friction status (frictionless case)" if status == "friction" and not friction \
            else f"{status} status"
        ax.set_title(f"{what} and {jump} at the {len(contact)} interface points: {counts}")
        ax.grid(alpha=0.3)
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = tw.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, loc="best", fontsize=8)
    axes[-1].set_xlabel("s, curvilinear abscissa along the interface (m)")
    fig.suptitle(f"{title}\ncontact and friction statuses along the interface")
    return fig


# -- (d) convergence --------------------------------------------------------------------
def convergence_figure(history: Sequence[float], iterations: Mapping[str, Any], title: str,
                       criterion: float | None = None, resi_frot: float | None = None) -> Figure:
    """Newton residual norms of every solve, and the friction threshold changes.

    ``history``: residual norms of every Newton iterate, solve after solve
    (``its + 1`` per solve); ``iterations``: results.json's record
    (``newton_per_solve``, ``contact`` per friction iteration,
    ``threshold_changes``, ``status_changes``); ``criterion``: the absolute
    Newton tolerance (RESI_GLOB_RELA x load norm).
    """
    per_solve = list(iterations.get("newton_per_solve", []))
    contact = list(iterations.get("contact", []))
    thr = list(iterations.get("threshold_changes", []))
    changes = list(iterations.get("status_changes", []))
    fig = _figure(12 if thr else 8, 5.5, left=0.07 if thr else 0.1, right=0.985, bottom=0.1, top=0.8,
                  wspace=0.22)
    axes = fig.subplots(1, 2 if thr else 1, squeeze=False)[0]
    ax = axes[0]
    h = np.maximum(np.asarray(history, float), 1e-300)
    start = 0
    friction = bool(iterations.get("friction"))
    labels = _solve_labels(contact, len(per_solve), friction)
    for i, its in enumerate(per_solve):
        seg = h[start:start + its + 1]
        xs = np.arange(start, start + len(seg))
        ax.semilogy(xs, seg, "o-", color=f"C{i % 10}", ms=4, label="Newton solve" if i == 0 else None)
        note = labels[i] + (f"\nthen {changes[i]} status changes" if i < len(changes) and changes[i] else "")
        ax.annotate(note, (xs[0], seg[0]), textcoords="offset points", xytext=(3, 4), fontsize=7,
                    color=f"C{i % 10}")
        if i:
            ax.axvline(start - 0.5, color="0.7", lw=0.8)
        start += len(seg)
    if criterion:
        ax.axhline(criterion, color="k", ls="--", lw=1, label=f"criterion {criterion:.2g}")
    if len(h):
        ax.set_ylim(top=float(h.max()) * 100)            # room for the labels above the first points
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    plain_log_labels(ax)
    ax.set_xlabel("residual evaluation (all Newton solves in order)")
    ax.set_ylabel("Newton residual norm |R| (N)")
    key = "F<i> C<j>: friction iteration i, contact iteration j" if friction else "C<j>: contact iteration j"
    ax.set_title(f"Newton residuals, solve after solve\n({key})", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="best")
    if thr:
        ax2 = axes[1]
        k = np.arange(1, len(thr) + 1)
        ax2.semilogy(k, np.maximum(thr, 1e-300), "s-", color="C3", label="relative change of LAGS_C")
        if resi_frot:
            ax2.axhline(resi_frot, color="k", ls="--", lw=1, label=f"RESI_FROT {resi_frot:.2g}")
        ax2.set_xticks(k)
        plain_log_labels(ax2)
        ax2.set_xlabel("friction threshold iteration")
        ax2.set_ylabel("max |dLAGS_C| / max |LAGS_C| (-)")
        ax2.set_title("friction threshold loop")
        ax2.grid(alpha=0.3, which="both")
        ax2.legend(fontsize=8)
    fig.suptitle(f"{title}\nconvergence: {len(per_solve)} Newton solves, {sum(per_solve)} iterations")
    return fig


def _solve_labels(contact: Sequence[int], n: int, friction: bool = True) -> list[str]:
    """"F<i> C<j>" (friction iteration i, contact iteration j) of each Newton solve
    ("C<j>" without friction loop)."""
    out: list[str] = []
    for f, c in enumerate(contact):
        out += [(f"F{f + 1} " if friction else "") + f"C{j + 1}" for j in range(c)]
    return (out + [""] * n)[:n]


# -- driver ----------------------------------------------------------------------------
#: savefig options: zlib level 1 (level 6 spent half the saving time for files 8 % smaller)
SAVE_OPTIONS = {"pil_kwargs": {"compress_level": 1}}


def line_jobs(title: str, table: InterfaceTable | None = None, history: Sequence[float] | None = None,
              iterations: Mapping[str, Any] | None = None, criterion: float | None = None,
              resi_frot: float | None = None) -> list[Job]:
    """The plots that need only the interface table and the iteration record, as jobs
    ``[(png name, function name, args)]`` (see :func:`run`)."""
    jobs: list[Job] = []
    if table is not None and len(table.columns.get("s", ())):
        jobs.append(("plot_multipliers.png", "multipliers_figure", (table.columns, title, table.curves)))
    if history is not None and iterations and len(iterations.get("newton_per_solve", [])) > 1:
        jobs.append(("plot_convergence.png", "convergence_figure", (history, iterations, title, criterion,
                                                                    resi_frot)))
    return jobs


def mesh_jobs(title: str, post: PostMesh | None = None, table: InterfaceTable | None = None,
              young: float = 0.0, friction: bool = True, multipliers: bool = True,
              references: Mapping[str, Callable[..., Any]] | None = None,
              profile: tuple[Sequence[float] | None, Sequence[float] | None] = (None, None)) -> list[Job]:
    """The plots that need the post-processing mesh (the status plot scales its jump
    axes with the largest displacement): the deformed mesh, reduced by
    :func:`deformed_data` to what the picture shows, and the statuses; in 3-D those of
    :func:`xfemcontact.post.plots3d.jobs` (``multipliers``: the interface has LAGS_C;
    ``references``: the case's formulas of x, y, z for the profiles; ``profile``: the
    ``[output]`` profile point and normal, None for the defaults)."""
    umax, size = 0.0, 1.0
    if post is not None and len(post.points):
        umax = float(np.nan_to_num(np.linalg.norm(post.displacement(), axis=1)).max()) \
            if post.points.shape[1] == 3 else \
            float(np.nan_to_num(np.hypot(post.point_data["DX"], post.point_data["DY"])).max())
        size = float(np.max(_column_max(post.points) - _column_min(post.points))) or 1.0
    jobs: list[Job] = []
    if table is not None and len(table.columns.get("s", ())):
        jobs.append(("plot_status.png", "status_figure", (table.columns, title, umax, friction)))
    if post is not None and post.points.shape[1] == 2:
        data = deformed_data(post.points, post.blocks, post.point_data, post.cell_data,
                             stress_scale=young * umax / size)
        jobs.append(("plot_deformed.png", "draw_deformed", (data, title)))
    elif post is not None:                                      # 3-D
        from xfemcontact.post import plots3d

        jobs += plots3d.jobs(title, post, multipliers, young * umax / size, references, *profile)
    return jobs


#: the plots of a 2-D run with an interface, and the order of every plot in report.md
PLOTS_2D = ("plot_multipliers.png", "plot_status.png", "plot_deformed.png", "plot_convergence.png")
ORDER = ("plot_multipliers.png", "plot_status.png", "plot_interface.png", "plot_profiles.png",
         "plot_deformed.png", "plot_convergence.png")


def figure_function(name: str) -> Callable[..., Figure]:
    """The function of a job (:data:`Job`): a function of this module, or ``module.name``
    of a module of :mod:`xfemcontact.post` (the 3-D plots: ``plots3d.draw_interface``)."""
    if "." in name:
        module, name = name.rsplit(".", 1)
        function: Callable[..., Figure] = getattr(importlib.import_module(f"xfemcontact.post.{module}"), name)
        return function
    found: Callable[..., Figure] = globals()[name]
    return found


def run(folder: Folder, jobs: Sequence[Job]) -> list[str]:
    """Draw ``jobs`` into ``folder`` (an OutputFolder, or anything with ``file(name)``); returns the names written."""
    if not jobs:
        return []
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    written: list[str] = []
    for name, function, args in jobs:
        try:
            fig = figure_function(function)(*args)
            FigureCanvasAgg(fig)             # the figure is drawn once, by savefig
            fig.savefig(folder.file(name), **SAVE_OPTIONS)
        except (ValueError, IndexError, TypeError, OverflowError, FloatingPointError,
                RuntimeError) as exc:
            # a plot that cannot be drawn (non-finite results of a failed run) is left
            # out: the result files matter more
            print(f"warning: {name} not drawn ({type(exc).__name__})", file=sys.stderr, flush=True)
            continue
        written.append(name)
    return written


def write(folder: Folder, title: str, post: PostMesh | None = None, table: InterfaceTable | None = None,
          history: Sequence[float] | None = None, iterations: Mapping[str, Any] | None = None,
          criterion: float | None = None, resi_frot: float | None = None, young: float = 0.0,
          friction: bool = True) -> list[str]:
    """Draw every plot the data allows into ``folder`` (rank 0); returns the names.

    ``young`` (Pa) sets the stress scale of the colour range (E max|u| / size).
    """
    title = title.replace("$", r"\$")        # text, not mathtext
    jobs = line_jobs(title, table, history, iterations, criterion, resi_frot) + \
        mesh_jobs(title, post, table, young, friction)
    jobs.sort(key=lambda j: ORDER.index(j[0]))
    return run(folder, jobs)
