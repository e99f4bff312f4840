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

Each ``*_figure`` function returns a :class:`matplotlib.figure.Figure` built from
plain arrays (the columns of interface.csv, the post mesh, results.json's
iteration record), so a plot can be redrawn from the files.
"""
import sys

import numpy as np

#: polygon node order of each cell type (vertices and mid-edge nodes around the boundary)
OUTLINE = {"quad8": [0, 4, 1, 5, 2, 6, 3, 7], "triangle6": [0, 3, 1, 4, 2, 5]}
EDGES = {"quad8": [(0, 4, 1), (1, 5, 2), (2, 6, 3), (3, 7, 0)],
         "triangle6": [(0, 3, 1), (1, 4, 2), (2, 5, 0)]}
DEFORMATION = 0.05          # largest displayed displacement / domain size
FIELD_UNITS = {"LAGS_C": "Pa", "LAGS_F1": "-", "gap": "m", "slip": "m", "SIYY": "Pa"}
SIDE_STYLE = {-1: dict(color="tab:red", lw=1.6, ls="-", label="interface, LN < 0 side"),
              1: dict(color="black", lw=1.0, ls="--", label="interface, LN > 0 side")}


def _figure(w, h):
    from matplotlib.figure import Figure

    return Figure(figsize=(w, h), dpi=110, layout="constrained")


def _curves(cols):
    """Row indices of each curve of an interface table."""
    return [np.nonzero(cols["curve"] == c)[0] for c in np.unique(cols["curve"])]


# -- (a) multipliers along s ---------------------------------------------------------
def multipliers_figure(cols, title, curves=None, fields=("LAGS_C", "LAGS_F1")):
    """LAGS_C, LAGS_F1 against s.

    ``cols``: interface.csv columns (``s``, the fields, optional
    ``<field>_ref``/``_err``); ``curves``: optional dense polylines with
    ``s`` and ``<field>_ref`` for smooth reference lines.  Lines carry labels
    ``"<field> computed"``, ``"<field> reference"``, ``"<field> error"``.
    """
    has_ref = any(f + "_ref" in cols for f in fields)
    fig = _figure(12 if has_ref else 7.5, 6.5)
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
def deformed_figure(points, blocks, point_data, cell_data, title, field="SIYY", stress_scale=0.0):
    """The deformed post mesh coloured by the cell field ``field``.

    ``points (np, 2)`` m; ``blocks`` [(meshio type, conn)]; ``point_data`` with
    DX, DY (m) and NFISSU; ``cell_data`` {name: [per block]}; ``stress_scale``
    (Pa, e.g. E max|u| / size): the colour range spans at least 1e-3 of it.
    """
    from matplotlib.collections import LineCollection, PolyCollection

    u = np.c_[point_data["DX"], point_data["DY"]]
    size = float(np.max(points.max(axis=0) - points.min(axis=0))) if len(points) else 1.0
    umax = float(np.abs(np.hypot(u[:, 0], u[:, 1])).max()) if len(u) else 0.0
    scale = DEFORMATION * size / umax if umax > 0 else 0.0
    xd = points + scale * u
    polys = [xd[conn[:, OUTLINE[t]]] for t, conn in blocks]
    values = np.concatenate(cell_data[field]) if field in cell_data else None
    fig = _figure(8.5, 7.5)
    ax = fig.subplots()
    pc = PolyCollection([p for block in polys for p in block], edgecolors="0.25", linewidths=0.25)
    if values is not None:
        pc.set_array(values)
        pc.set_cmap("viridis")
        pc.set_clim(*_colour_limits(values, stress_scale))
    ax.add_collection(pc)
    nf = point_data.get("NFISSU")
    if nf is not None:
        for side in (-1, 1):
            segs = _interface_edges(blocks, nf, side, xd)
            if len(segs):
                ax.add_collection(LineCollection(segs, **SIDE_STYLE[side]))
        if (nf != 0).any():
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=2, fontsize=9, frameon=False)
    ax.autoscale_view()
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if values is not None:
        cb = fig.colorbar(pc, ax=ax, shrink=0.85)
        cb.set_label(f"{field} ({FIELD_UNITS.get(field, '')}), mean per cell and sub-cell\n"
                     f"min {values.min():.7g}, max {values.max():.7g}")
        cb.formatter.set_useOffset(False)
        cb.update_ticks()
    how = f"displacements x {scale:.3g}" if scale > 0 else "no displacement"
    fig.suptitle(f"{title}\ndeformed mesh, {how} (max |u| = {umax:.3g} m), coloured by {field}")
    return fig


def _colour_limits(v, scale=0.0):
    """Data range, widened to +-1e-3 max(|mean|, scale) around the mean when the field
    is nearly uniform (so round-off does not paint a uniform field in every colour)."""
    lo, hi = float(np.min(v)), float(np.max(v))
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    floor = 1e-3 * max(abs(mid), scale, 1e-300)
    if half < floor:
        half = floor if mid != 0 else 1.0
    return mid - half, mid + half


def _interface_edges(blocks, nfissu, side, xd):
    """Polylines (a, mid, b) of the cell edges lying on the interface, copies of ``side``."""
    out = []
    for t, conn in blocks:
        e = np.array(EDGES[t])
        nodes = conn[:, e]                                                    # (k, ne, 3)
        on = np.all(nfissu[nodes] == side, axis=2)
        out.append(xd[nodes[on]])
    return np.concatenate(out) if out else np.zeros((0, 3, 2))


# -- (c) statuses along s ---------------------------------------------------------------
def status_figure(cols, title, jump_scale=0.0, friction=True):
    """Contact and sliding statuses along s (steps), with the gap and slip (twin axes).

    ``jump_scale`` (m): the gap and slip axes span at least +-1e-3 of it (a
    typical displacement), so round-off jumps show as zero, not as noise.
    The friction state is -1 where the point is open (no friction), else
    0 stick / 1 slip.
    """
    fig = _figure(10, 6.5)
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
def convergence_figure(history, iterations, title, criterion=None, resi_frot=None):
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
    fig = _figure(12 if thr else 8, 5.5)
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
        ax2.set_xlabel("friction threshold iteration")
        ax2.set_ylabel("max |dLAGS_C| / max |LAGS_C| (-)")
        ax2.set_title("friction threshold loop")
        ax2.grid(alpha=0.3, which="both")
        ax2.legend(fontsize=8)
    fig.suptitle(f"{title}\nconvergence: {len(per_solve)} Newton solves, {sum(per_solve)} iterations")
    return fig


def _solve_labels(contact, n, friction=True):
    """"F<i> C<j>" (friction iteration i, contact iteration j) of each Newton solve
    ("C<j>" without friction loop)."""
    out = []
    for f, c in enumerate(contact):
        out += [(f"F{f + 1} " if friction else "") + f"C{j + 1}" for j in range(c)]
    return (out + [""] * n)[:n]


# -- driver ----------------------------------------------------------------------------
def write(folder, title, post=None, table=None, history=None, iterations=None,
          criterion=None, resi_frot=None, young=0.0, friction=True):
    """Draw every plot the data allows into ``folder`` (rank 0); returns the names.

    ``young`` (Pa) sets the stress scale of the colour range (E max|u| / size).
    """
    written = []
    umax, size = 0.0, 1.0
    title = title.replace("$", r"\$")        # text, not mathtext
    if post is not None and len(post.points):
        umax = float(np.nan_to_num(np.hypot(post.point_data["DX"], post.point_data["DY"])).max())
        size = float(np.max(post.points.max(axis=0) - post.points.min(axis=0))) or 1.0

    def save(draw, name):
        """A plot that cannot be drawn (non-finite results of a failed run) is left out:
        the result files matter more."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        try:
            fig = draw()
            FigureCanvasAgg(fig)             # the figure is drawn once, by savefig
            fig.savefig(folder.file(name))
        except (ValueError, IndexError, TypeError, OverflowError, FloatingPointError,
                RuntimeError) as exc:
            print(f"warning: {name} not drawn ({type(exc).__name__})", file=sys.stderr, flush=True)
            return
        written.append(name)

    if table is not None and len(table.columns["s"]):
        save(lambda: multipliers_figure(table.columns, title, table.curves), "plot_multipliers.png")
        save(lambda: status_figure(table.columns, title, umax, friction), "plot_status.png")
    if post is not None:
        save(lambda: deformed_figure(post.points, post.blocks, post.point_data, post.cell_data, title,
                                     stress_scale=young * umax / size), "plot_deformed.png")
    if history is not None and iterations and len(iterations.get("newton_per_solve", [])) > 1:
        save(lambda: convergence_figure(history, iterations, title, criterion, resi_frot),
             "plot_convergence.png")
    return written
