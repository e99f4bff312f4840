"""report.md: a one-page Markdown summary of a run, from results.json's content.

Written during the output phase, so its timings stop there (results.json has
the output phase and the total).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Iterable, Sequence

if TYPE_CHECKING:
    from xfemcontact.output.folder import OutputFolder

FILE_NOTES = {
    "fields.xdmf": "post-processing mesh and fields (ParaView: open this file)",
    "fields.h5": "HDF5 data of fields.xdmf",
    "fields.vtu": "post-processing mesh and fields, VTK format",
    "fields.med": "post-processing mesh and fields, MED format (Salome, code_aster)",
    "interface.csv": "interface point values along the curvilinear abscissa s",
    "plot_multipliers.png": "LAGS_C and LAGS_F1 along the interface",
    "plot_deformed.png": "deformed mesh coloured by SIYY",
    "plot_status.png": "contact and friction statuses along the interface",
    "plot_convergence.png": "Newton residuals and friction threshold loop",
    "results.json": "every number of this report, machine-readable",
}


def _num(v: object, fmt: str = ".6g") -> str:
    return "-" if v is None else format(v, fmt) if isinstance(v, float) else str(v)


def _table(header: Sequence[str], rows: Iterable[Sequence[object]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return lines


def render(summary: dict[str, Any], files: Iterable[str], case_source: str = "",
           warnings: Iterable[str] = ()) -> str:
    """The Markdown text.  ``summary``: results.summary(); ``files``: names written."""
    s = summary
    ok = all(t["ok"] for t in s["tests"])
    status = "converged" if s["converged"] else "NOT converged"
    if not s["converged"]:
        verdict = "tests not evaluated (the fields are the last iterate)"
    else:
        verdict = "no tests" if not s["tests"] else ("all tests OK" if ok else "some tests NOOK")
    out = [f"# {s['title']}", "",
           f"Case `{s['case']}`" + (f" (`{case_source}`)" if case_source else "")
           + f", xfemcontact {s['xfemcontact']}, {s['processes']} process(es): "
           f"**{status}** (SNES reason {s['reason']}), **{verdict}**.", ""]
    m = s["mesh"]
    out += ["## Mesh and unknowns", "",
            f"{m['cells']} {m['cell_type']} cells, {m['nodes']} nodes."]
    g = s.get("geometry")
    if g:
        on = f"{g['edge_segments']} segments on cell edges" if "interface_facets" not in g else \
            f"{g['interface_facets']} facets (area {g['interface_area']:.6g} m^2)"
        out.append(f"Interface: {g['cut_cells']} cut cells, {on}, "
                   f"{g['enriched_nodes']} Heaviside-enriched nodes "
                   f"({g['dropped_heaviside_nodes']} dropped by the conditioning rule).")
    out.append("")
    d = s["dofs"]
    out += _table(["displacement", "heaviside", "LAGS_C", "LAGS_F1", "total"],
                  [[d.get("displacement"), d.get("heaviside"), d.get("LAGS_C"), d.get("LAGS_F1"), d.get("total")]])
    out.append("")
    mp = s.get("multipliers")
    if mp:
        out += ["Multiplier space: " + ", ".join(f"{k.replace('_', ' ')} {_num(v, '.3g')}" for k, v in mp.items())
                + ".", ""]
    it = s["iterations"]
    out += ["## Iterations", ""]
    if "newton_per_solve" in it:
        out += [f"- Newton: {it['newton']} iterations in {len(it['newton_per_solve'])} solves "
                f"({', '.join(map(str, it['newton_per_solve']))})",
                f"- contact status loop: {', '.join(map(str, it['contact']))} iterations "
                f"(status changes after each solve: {', '.join(map(str, it['status_changes']))})",
                f"- friction threshold loop: {it['friction']} iterations (relative changes of LAGS_C: "
                f"{', '.join(format(c, '.2e') for c in it['threshold_changes'])})"]
    else:
        out.append(f"- Newton: {it['newton']} iterations")
    hist = s.get("residual_history") or []
    if hist:
        out.append(f"- residual norms: first {hist[0]:.3e}, last {hist[-1]:.3e}")
    ls = s.get("linear_solver")
    if ls:
        txt = f"- linear solver: {ls.get('ksp')} / {ls.get('pc')}" + (f" ({ls['solver']})" if "solver" in ls else "")
        txt += f", {ls.get('jacobians')} Jacobians"
        if "mumps" in ls:
            txt += f", MUMPS null pivots {ls['mumps']['null_pivots']}"
        out.append(txt)
    out.append("")
    out += ["## Tests", ""]
    if s["tests"]:
        out += _table(["", "test", "field", "type", "computed", "reference", "error", "tolerance", "criterion", "at"],
                      [["OK" if t["ok"] else "**NOOK**", t["name"], t["field"], t["type"],
                        _number(t["value"], ".10e", "no point selected" if not t.get("samples") else "-"),
                        f"{t['reference']:.10e}", _number(t["error"], ".3e"), f"{t['tolerance']:.2e}", t["criterion"],
                        "-" if not t.get("at") else "(" + ", ".join(f"{c:.6g}" for c in t["at"]) + ")"] for t in s["tests"]])
    else:
        out.append("No tests in the case." if s["converged"] else "Not converged: no test evaluated.")
    out += ["", "## Timings (s)", ""]
    tm = s["timings"]
    out += _table(list(tm), [[f"{v:.3f}" for v in tm.values()]])
    out += ["", "(the output phase and the total are in results.json)", ""]
    allw = list(s.get("warnings") or []) + list(warnings)
    out += ["## Warnings", ""] + ([f"- {w}" for w in allw] or ["None."]) + [""]
    out += ["## Files", ""]
    out += [f"- [{f}]({f}): {FILE_NOTES.get(f, '')}" for f in list(files) + ["results.json"]]
    return "\n".join(out) + "\n"


def write(folder: OutputFolder, summary: dict[str, Any], files: Iterable[str], case_source: str = "",
          warnings: Iterable[str] = ()) -> list[str]:
    """Write report.md (rank 0); returns ``["report.md"]``."""
    folder.write_text("report.md", render(summary, files, case_source, warnings))
    return ["report.md"]


def _number(v: float | None, fmt: str, missing: str = "-") -> str:
    """``v`` formatted, or ``missing`` when it is None or not finite."""
    return format(v, fmt) if v is not None and math.isfinite(v) else missing
