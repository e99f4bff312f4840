"""Result files of a run with ``[instants]``: the same files as a one-step run, over time.

* ``fields.xdmf`` + ``fields.h5``: an XDMF temporal collection (ParaView animates
  it): the post-processing mesh once (cut cells as their sub-triangles, interface
  points duplicated), its point and cell fields at every completed step;
* ``interface.xdmf`` + ``interface.h5`` (3-D with an interface): the interface surface
  (:mod:`xfemcontact.post.surface`) as a temporal collection the same way: its facets
  once, LAGS_C, LAGS_F1, LAGS_F2, T, gap, slip, the statuses ... at every completed step;
* ``fields.vtu`` / ``interface.vtu`` / ``fields.med`` (if asked): the last completed step;
* ``interface.csv``: the interface table of every completed step, one block of
  rows per step, with the columns ``inst`` (first) and ``slip_path`` (the
  accumulated slip: the sum over the steps of |slip increment|, m) besides the
  one-step columns; reference columns evaluated at each instant;
* ``plot_history.png``: LAGS_C, LAGS_F1 (and LAGS_F2 in 3-D) and the slip against
  time at five interface points (s = 0, L/4, L/2, 3L/4, L along the first curve; 3-D:
  the first, last and quartile points along the coordinate the interface spans most),
  and the load path (each load's mean value over its group against time);
* the one-step plots and ``report.md`` of the last completed step.

The fields of every step are rebuilt from its checkpoint (solution and contact
state), so a resumed run writes the same files as an uninterrupted one.
"""
from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any, Callable, Iterable

import numpy as np

from xfemcontact import timing
from xfemcontact.output import interface_csv

if TYPE_CHECKING:
    import meshio
    from matplotlib.figure import Figure
    from numpy.typing import NDArray

    from xfemcontact.history.checkpoint import Checkpoints
    from xfemcontact.history.stepping import Stepper
    from xfemcontact.model import Model
    from xfemcontact.output.folder import OutputFolder
    from xfemcontact.output.interface_csv import InterfaceTable
    from xfemcontact.post.postmesh import PostMesh
    from xfemcontact.post.testtable import Outcome

    #: interface.csv columns by name
    Columns = dict[str, NDArray[Any]]
    #: a panel of the history plot: (y label, [(line label, values at every instant)])
    Panel = tuple[str, list[tuple[str, NDArray[np.float64]]]]

#: fractions of the first curve's length where the history plot follows the interface
HISTORY_POINTS = (0.0, 0.25, 0.5, 0.75, 1.0)


def write_fields(folder: OutputFolder, model: Model, stepper: Stepper,
                 checkpoints: Checkpoints) -> tuple[PostMesh | None, list[str]]:
    """fields.xdmf as a time series, in 3-D with an interface interface.xdmf too (and
    fields.vtu / interface.vtu / fields.med at the last step, as
    :func:`xfemcontact.output.results.write_meshio_formats`).  Collective.  Leaves the
    model at its last completed step; returns the PostMesh of that step (rank 0) and the
    names written."""
    from xfemcontact.output import results
    from xfemcontact.post import postmesh

    formats = model.case.output.formats
    steps = stepper.steps
    writers: dict[str, _TimeSeries] = {}          # by file stem (results.field_meshes)
    post = None
    frames = [(i + 1, s["inst"]) for i, s in enumerate(steps)] or [(0, stepper.time)]
    try:
        for index, t in frames:
            if index:
                with timing.step("output:load_step"):
                    checkpoints.load(model, index)
                    stepper.loads.apply(t)
            with timing.step("output:postmesh"):
                post = postmesh.build(model)
            if post is None or "xdmf" not in formats:
                continue
            with timing.step("output:xdmf"):
                for name, mesh in results.field_meshes(post):
                    _frame(folder, writers, name, t, mesh.to_meshio())
    finally:
        for writer in writers.values():
            writer.close()
    written = [f"{name}{ext}" for name in writers for ext in (".xdmf", ".h5")]
    if post is not None:
        written += results.write_meshio_formats(folder, post, formats)
    return post, written


def _frame(folder: OutputFolder, writers: dict[str, _TimeSeries], name: str, t: float, m: meshio.Mesh) -> None:
    """Write the fields of ``m`` at instant ``t`` (s) into the time series ``name``.xdmf,
    opened (with ``m``'s points and cells, the same at every instant) at its first frame."""
    writer = writers.get(name)
    if writer is None:
        writer = writers[name] = _TimeSeries(folder, f"{name}.xdmf")
        writer.mesh(m)
    writer.frame(t, m)


class _TimeSeries:
    """meshio's XDMF time-series writer, writing into the output folder with a relative
    HDF5 path (the folder is renamed afterwards)."""

    def __init__(self, folder: OutputFolder, name: str) -> None:
        import meshio

        self._cwd = os.getcwd()
        os.chdir(folder.file("."))
        try:
            self._writer = meshio.xdmf.TimeSeriesWriter(name, data_format="HDF")
            self._writer.__enter__()
        except BaseException:
            os.chdir(self._cwd)
            raise
        os.chdir(self._cwd)
        self._folder = folder

    def _inside(self, fn: Callable[..., Any], *args: Any) -> Any:
        os.chdir(self._folder.file("."))
        try:
            return fn(*args)
        finally:
            os.chdir(self._cwd)

    def mesh(self, m: meshio.Mesh) -> None:
        self._inside(self._writer.write_points_cells, m.points, m.cells)

    def frame(self, t: float, m: meshio.Mesh) -> None:
        cell_data = {k: list(v) for k, v in m.cell_data.items()}
        self._inside(lambda: self._writer.write_data(float(t), point_data=dict(m.point_data),
                                                      cell_data=cell_data))

    def close(self) -> None:
        self._inside(self._writer.__exit__, None, None, None)


def interface_rows(model: Model, stepper: Stepper) -> tuple[InterfaceTable | None, Columns | None]:
    """The interface.csv columns of every completed step (rank 0; None elsewhere or
    without interface): the last step's table (:func:`interface_csv.build`) gives the
    row order (and the curves in 2-D), each step its values.  3-D: the facets' Gauss
    points, the columns of :data:`interface_csv.COLUMNS_3D`."""
    table = interface_csv.build(model)
    if table is None or model.comm.rank != 0:
        return table, None
    steps = [s for s in stepper.steps if "interface" in s]
    if not steps:
        return table, None
    cols = table.columns
    three = model.mesh.dim == 3
    rows = _rows_of(cols, steps[-1]["interface"], three)
    if rows is None:               # cannot happen: same points at every step
        return table, None
    columns = interface_csv.COLUMNS_3D if three else interface_csv.COLUMNS
    fixed = ("x", "y", "z", "cell", "w") if three else ("curve", "s", "x", "y", "cell")
    names = ["inst"] + list(columns) + ["slip_path"]
    out: dict[str, list[NDArray[Any]]] = {name: [] for name in names}
    ref_names = [f for f in interface_csv.REFERENCE_FIELDS if f in model.case.reference]
    for f in ref_names:
        out[f + "_ref"], out[f + "_err"] = [], []
    coords = {c: cols[c] for c in (("x", "y", "z") if three else ("x", "y"))}
    n = len(rows)
    for step in steps:
        values = step["interface"]
        out["inst"].append(np.full(n, step["inst"]))
        for name in columns:
            if name in fixed:
                out[name].append(np.asarray(cols[name]))
            else:
                out[name].append(np.asarray(values[name], dtype=float)[rows])
        out["slip_path"].append(np.asarray(values["slip_path"], dtype=float)[rows])
        for f in ref_names:
            formula = model.case.reference[f].at(step["inst"])
            try:
                ref = np.broadcast_to(np.asarray(formula(**coords), float), (n,)).copy()
            except Exception:                   # invalid somewhere on the interface
                ref = np.full(n, np.nan)
            out[f + "_ref"].append(ref)
            out[f + "_err"].append(np.asarray(values[f], dtype=float)[rows] - ref)
    return table, {k: np.concatenate(v) for k, v in out.items()}


def _rows_of(cols: Columns, values: dict[str, Any], three: bool) -> NDArray[np.int64] | None:
    """For each row of the table ``cols``, its index in a step's interface table ``values``
    (the same points: matched by cell and coordinates); None if one is missing."""
    keys = ("cell", "x", "y", "z") if three else ("cell", "x", "y")

    def key(src: Any, i: int) -> tuple[float, ...]:
        return tuple(float(src[k][i]) for k in keys)
    where = {key(values, i): i for i in range(len(values["cell"]))}
    rows = np.array([where.get(key(cols, i), -1) for i in range(len(cols["cell"]))], dtype=np.int64)
    return None if (rows < 0).any() else rows


def write_interface_csv(folder: OutputFolder, columns: Columns, name: str = "interface.csv") -> list[str]:
    """Write the columns of every step (:func:`interface_rows`) as ``name``; returns ``[name]``."""
    names = list(columns)
    data = np.column_stack([np.asarray(columns[c], dtype=float) for c in names])
    fmt = ["%d" if c in interface_csv.INTEGER_COLUMNS else "%.17g" for c in names]
    np.savetxt(folder.file(name), data, fmt=fmt, delimiter=",", header=",".join(names), comments="")
    return [name]


def history_figure(stepper: Stepper, table: InterfaceTable | None, title: str) -> Figure:
    """LAGS_C, LAGS_F1, slip against time at a few interface points, and the load path."""
    from matplotlib.figure import Figure

    steps = stepper.steps
    t0 = stepper.instants.values[0]
    ts = np.r_[t0, [s["inst"] for s in steps]]
    panels: list[Panel] = []
    if table is not None and steps and "interface" in steps[-1]:
        picks = _history_points(table, steps[-1]["interface"])
        fields = (("LAGS_C", "Pa"), ("LAGS_F1", "-")) + \
            ((("LAGS_F2", "-"),) if "LAGS_F2" in table.columns else ()) + (("slip", "m"),)
        for field, unit in fields:
            lines = [(label, np.r_[0.0, [st["interface"][field][i] for st in steps]]) for label, i in picks]
            panels.append((f"{field} ({unit})", lines))
    loads: dict[str, None] = {}                # labels, in order of appearance
    for st in steps:
        for label in st.get("loads", {}):
            loads.setdefault(label, None)
    imposed: list[tuple[str, NDArray[np.float64]]] = []
    forces: list[tuple[str, NDArray[np.float64]]] = []
    for label in loads:
        v = np.r_[np.nan, [st.get("loads", {}).get(label, np.nan) for st in steps]]
        if not np.any(np.nan_to_num(v)):          # zero at every instant: left out
            continue
        (imposed if label.startswith("dirichlet") else forces).append((label, v))
    if imposed:
        panels.append(("imposed displacement (m,\nmean over its group)", imposed))
    if forces:
        panels.append(("load (N/m, Pa, N/m3,\nmean over its group)", forces))
    fig = Figure(figsize=(8.0, 2.3 * len(panels)), constrained_layout=True)
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (ylabel, lines) in zip(axes, panels):
        for label, v in lines:
            ax.plot(ts, v, marker="o", ms=3, label=label)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
        if lines:
            ax.legend(fontsize=7, loc="best")
    axes[0].set_title(title.replace("$", r"\$"), fontsize=10)
    axes[-1].set_xlabel("instant t")
    return fig


def _history_points(table: InterfaceTable, last: dict[str, Any]) -> list[tuple[str, int]]:
    """The interface points the history plot follows, as (label, index in the steps'
    interface tables): 2-D, at the fractions :data:`HISTORY_POINTS` of the first curve's
    length; 3-D (no curves), at those fractions of the rows ordered along the coordinate
    the interface spans most."""
    cols = table.columns
    three = "z" in cols
    keys = ("cell", "x", "y", "z") if three else ("cell", "x", "y")
    where = {tuple(float(last[k][i]) for k in keys): i for i in range(len(last["cell"]))}
    if three:
        xyz = np.c_[cols["x"], cols["y"], cols["z"]]
        axis = int(np.argmax(np.ptp(xyz, axis=0))) if len(xyz) else 0
        order = np.lexsort((xyz[:, (axis + 2) % 3], xyz[:, (axis + 1) % 3], xyz[:, axis]))
        rows = [int(order[round(f * (len(order) - 1))]) for f in HISTORY_POINTS] if len(order) else []
    else:
        first = np.flatnonzero(cols["curve"] == cols["curve"].min())
        s = np.asarray(cols["s"])[first]
        length = s.max() if len(s) else 0.0
        rows = [int(first[np.argmin(np.abs(s - f * length))]) for f in HISTORY_POINTS]
    picks: list[tuple[str, int]] = []
    for row in rows:
        i = where.get(tuple(float(cols[k][row]) for k in keys))
        if i is None or i in [p[1] for p in picks]:
            continue
        at = ", ".join(f"{cols[c][row]:.3g}" for c in keys[1:])
        picks.append((f"({at})" if three else f"s = {cols['s'][row]:.3g} m ({at})", i))
    return picks


def write_outputs(folder: OutputFolder, model: Model, stepper: Stepper, checkpoints: Checkpoints,
                  converged: bool, reason: int, outcomes: Iterable[Outcome],
                  warnings: Iterable[str] = ()) -> dict[str, Any]:
    """Every result file but results.json (see the module documentation).  Collective;
    only rank 0 writes.  Returns the summary of the last completed step (rank 0)."""
    from xfemcontact.output import report, results
    from xfemcontact.post import plots

    post, files = write_fields(folder, model, stepper, checkpoints)
    table, columns = interface_rows(model, stepper)
    summary_now = results.summary(model, converged, reason, outcomes)
    if model.comm.rank != 0:
        return summary_now
    warnings = list(warnings)
    if columns is not None:
        files += write_interface_csv(folder, columns)
    elif table is not None:
        files += interface_csv.write(folder, table)
    if table is not None:
        warnings += table.warnings
    case = model.case
    title = case.title if converged else f"{case.title} -- NOT CONVERGED"
    if case.output.plots:
        criterion = case.newton.resi_glob_rela * model.load_norm if model.solver else None
        friction = bool(model.problem is not None and model.problem.friction)
        resi_frot = case.contact.resi_frot if model.solver and model.solver.record else None
        at = f"{title} (t = {stepper.time:g})"
        files += plots.write(folder, at, post=post, table=table,
                             history=summary_now["residual_history"],
                             iterations=summary_now["iterations"], criterion=criterion,
                             resi_frot=resi_frot, young=case.material.E, friction=friction)
        if stepper.steps:
            try:
                fig = history_figure(stepper, table, title)
                from matplotlib.backends.backend_agg import FigureCanvasAgg

                FigureCanvasAgg(fig)
                fig.savefig(folder.file("plot_history.png"))
                files.append("plot_history.png")
            except (ValueError, IndexError, TypeError, OverflowError, FloatingPointError,
                    RuntimeError) as exc:
                import sys

                print(f"warning: plot_history.png not drawn ({type(exc).__name__})", file=sys.stderr,
                      flush=True)
    report.write(folder, summary_now, files, case_source=case.source, warnings=warnings)
    return summary_now
