"""A family of floating inclusions held by contact and friction alone: how Newton fares.

    .venv/bin/python bench/inclusion_family.py                      # 30 runs, about 3 min on 2 cores
    .venv/bin/python bench/inclusion_family.py --cells QUAD8 --n 20 40
    .venv/bin/python bench/inclusion_family.py -- -xfc_friction_line_search NONE
    .venv/bin/python bench/inclusion_family.py --algo STABLE --name inclusion_family_stable

The template is ``cases/campaign/curved_inclusion_mixed_quad8.toml``: a circular inclusion of
radius R in a 10 m plate, the same material, held only by contact and Coulomb friction
(mu = 0.5), under sigma_xx = -100 Pa, sigma_yy = +20 Pa, sigma_xy = 30 Pa: open, slip and
stick zones side by side.  Its mesh (N x N cells, QUAD8 or TRIA6) and its radius change; each
variant is written into the scratch folder (``ITER_GLOB_MAXI`` 60, ``--algo``: the multiplier
space ``algo_lagr``, the rest as the template) and run with ``python -m xfemcontact run``, options after ``--`` passed on.

Printed, per run: converged, Newton iterations over the run, threshold iterations,
forced status loops (CONTACT3_86), the hand-overs of a stalled line search to the threshold
fixed point (``guards``), the largest condition violation at the dofs relative to the
scales (results.json ``conditions``) and the smallest point gap of interface.csv (m; the
displacements are about 1e-3 m).  With several mesh sizes it adds the point values between
the dofs (smallest gap at open and at closed points, largest slip at sticking points), worst
over the radii and ``--shift`` positions of the centre per size, and the rate at which the
worst gap falls: ``--n 20 28 40 56 80 113 160 --radius 2.3 --shift 0 0.25 0.5 0.75 --name
inclusion_point_floor`` (56 runs, about 5 min).  Written to ``bench/results/<name>.md`` and
``.json``.

These are the hardest cases we know for the semi-smooth Newton: the inclusion's rotation is
held by friction alone, so a Newton iterate where most contact dofs slip has a nearly singular
tangent (see :mod:`xfemcontact.solver.linesearch`).
"""
import argparse
import concurrent.futures
import csv
import json
import pathlib
import re
import shutil
import subprocess
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
TEMPLATE = ROOT / "cases" / "campaign" / "curved_inclusion_mixed_quad8.toml"
CONDITIONS = ("tension", "interpenetration", "contact_complementarity", "friction_excess",
              "friction_complementarity", "threshold")


def variant(text: str, cell: str, n: int, radius: float, algo: str | None = None,
            shift: float = 0.0) -> str:
    """The template with an n x n mesh of ``cell``, the inclusion's radius (m), its centre
    moved by ``shift`` cells along x and y (5 m + shift * 10 m / n each) and the multiplier
    space ``algo`` (None: the default)."""
    centre = 5.0 + shift * 10.0 / n
    text, k5 = re.subn(r"(?m)^xc = 5\.0$", f"xc = {centre!r}", text)
    text, k6 = re.subn(r"(?m)^yc = 5\.0$", f"yc = {centre!r}", text)
    if (k5, k6) != (1, 1):
        raise SystemExit(f"error: {TEMPLATE}: the template changed; update bench/inclusion_family.py")
    out, k = re.subn(r"nx = \d+, ny = \d+", f"nx = {n}, ny = {n}", text)
    out, k2 = re.subn(r'cell = "QUAD8"', f'cell = "{cell}"', out)
    out, k3 = re.subn(r"- 2\.3\*\*2", f"- {radius}**2", out)
    out, k4 = re.subn(r"iter_glob_maxi = \d+", "iter_glob_maxi = 60", out)
    if (k, k2, k3, k4) != (1, 1, 1, 1):
        raise SystemExit(f"error: {TEMPLATE}: the template changed; update bench/inclusion_family.py")
    if algo is not None:
        out = out.replace("[contact]\n", f'[contact]\nalgo_lagr = "{algo}"\n', 1)
    return out


def run(job: dict, options: list[str]) -> dict:
    """Run one variant; returns its row."""
    t0 = time.perf_counter()
    cmd = [sys.executable, "-m", "xfemcontact", "run", str(job["toml"]), "-o", str(job["out"]),
           "--overwrite", *options]
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    row = dict(name=job["name"], cell=job["cell"], n=job["n"], radius=job["radius"], rc=proc.returncode,
               seconds=round(time.perf_counter() - t0, 2))
    try:
        r = json.loads((job["out"] / "results.json").read_text())
    except (OSError, ValueError):
        row.update(converged=False, error=(proc.stderr.strip().splitlines() or ["no results.json"])[-1])
        return row
    it = r.get("iterations", {})
    cond = r.get("conditions") or {}
    try:
        with open(job["out"] / "interface.csv") as f:
            row.update(point_values(list(csv.DictReader(f))))
    except (OSError, ValueError, KeyError):
        row["min_gap"] = None
    row.update(converged=bool(r.get("converged")), newton=it.get("newton"), threshold=it.get("friction"),
               forced=sum("CONTACT3_86" in w for w in r.get("warnings", [])),
               guards=(r.get("multipliers") or {}).get("cycle_guards"),
               coarse=(it.get("coarse_start") or {}).get("newton"),
               coarse_used=(it.get("coarse_start") or {}).get("used"),
               conditions=max((float(cond[k]) for k in CONDITIONS if cond.get(k) is not None), default=None))
    return row


def point_values(points: list[dict]) -> dict:
    """The law at the interface points of interface.csv, between the dofs (m): the smallest
    gap overall, at the open points (contact 0: LAGS_C = 0 there) and at the closed ones
    (contact 1: where the law asks for gap = 0), and the largest |slip| at the sticking
    points (contact 1, sliding 0: where the law asks for slip = 0).  The dofs' own
    conditions are results.json's ``conditions``; these are the point values between them."""
    gap = [float(p["gap"]) for p in points]
    is_open = [int(p["contact"]) == 0 for p in points]
    stick = [not o and int(p["sliding"]) == 0 for o, p in zip(is_open, points)]
    return dict(min_gap=min(gap), max_lags_c=max(float(p["LAGS_C"]) for p in points),
                max_lags_f1=max(abs(float(p["LAGS_F1"])) for p in points),
                min_gap_open=min((g for g, o in zip(gap, is_open) if o), default=None),
                min_gap_closed=min((g for g, o in zip(gap, is_open) if not o), default=None),
                max_slip_stick=max((abs(float(p["slip"])) for p, s in zip(points, stick) if s), default=None))


def refinement(rows: list[dict], cells: list[str]) -> list[str]:
    """Per cell type and mesh size, the worst point values over the radii and shifts (the
    end of a contact zone falls elsewhere in its cell with each), and the factor from the
    previous size."""
    lines = ["", "Worst over radii and shifts, per mesh size (m; displacements about 1e-3 m), "
             "and the factor from the previous size:", "",
             "| cell | N | runs | min gap, open points | min gap, closed points | max slip, sticking points |",
             "|---|---|---|---|---|---|"]
    rates = []
    for cell in cells:
        prev, both = None, []
        for n in sorted({r["n"] for r in rows if r["cell"] == cell}):
            sub = [r for r in rows if r["cell"] == cell and r["n"] == n and r.get("converged")]
            worst = [max((abs(min(r.get(k) or 0.0, 0.0)) for r in sub), default=None)
                     for k in ("min_gap_open", "min_gap_closed")]
            worst.append(max((r.get("max_slip_stick") or 0.0 for r in sub), default=None))
            cols = []
            for i, w in enumerate(worst):
                f = "" if prev is None or not prev[i] or not w else f" (/{prev[i] / w:.1f})"
                cols.append("-" if w is None else f"{w:.1e}{f}")
            lines.append(f"| {cell} | {n} | {len(sub)} | " + " | ".join(cols) + " |")
            prev = worst
            if worst[0] is not None and max(worst[:2]) > 0:
                both.append((n, max(worst[:2])))
        if len(both) > 1:
            # least squares of log(worst gap) against log(h), h = 10 m / N
            slope = np.polyfit(np.log([10.0 / n for n, _ in both]), np.log([w for _, w in both]), 1)[0]
            rates.append(f"{cell}: the worst point gap (open or closed) falls like h^{slope:.2f} "
                         f"(least squares over N = {both[0][0]} ... {both[-1][0]})")
    return lines + [""] + rates


def write_results(name: str, lines: list[str], rows: list[dict]) -> None:
    """Print the table ``lines`` and write it with the ``rows`` to bench/results/<name>.md, .json."""
    out = "\n".join(lines)
    print(out)
    res = ROOT / "bench" / "results"
    res.mkdir(exist_ok=True)
    (res / f"{name}.md").write_text(out + "\n")
    (res / f"{name}.json").write_text(json.dumps(dict(argv=sys.argv[1:], rows=rows), indent=1, default=str))
    print(f"\nwrote {res / name}.md and .json")


def add_common_arguments(ap: argparse.ArgumentParser, name: str) -> None:
    """The options this script shares with bench/hard_inclusions.py (``name``: the
    default results name and scratch folder)."""
    ap.add_argument("--cells", nargs="+", default=["QUAD8", "TRIA6"], choices=["QUAD8", "TRIA6"])
    ap.add_argument("--slots", type=int, default=2, help="runs at a time")
    ap.add_argument("--scratch", default=f"/tmp/xfc_{name}")
    ap.add_argument("--name", default=name)
    ap.add_argument("--limit", type=int, default=25, help="Newton iterations counted as slow above this")
    ap.add_argument("options", nargs="*", help="xfemcontact options, after --")


def fresh_scratch(path: str) -> pathlib.Path:
    """The scratch folder ``path``, emptied."""
    scratch = pathlib.Path(path)
    shutil.rmtree(scratch, ignore_errors=True)
    scratch.mkdir(parents=True)
    return scratch


def run_all(jobs: list, slots: int, options: list) -> tuple[list, float]:
    """:func:`run` of every job, ``slots`` at a time: the rows and the seconds taken."""
    t0 = time.perf_counter()
    with concurrent.futures.ThreadPoolExecutor(slots) as pool:
        rows = list(pool.map(lambda j: run(j, options), jobs))
    return rows, time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_common_arguments(ap, "inclusion_family")
    ap.add_argument("--n", nargs="+", type=int, default=[16, 20, 24, 30, 40], help="cells per side")
    ap.add_argument("--radius", nargs="+", type=float, default=[2.1, 2.3, 2.45], help="m")
    ap.add_argument("--shift", nargs="+", type=float, default=[0.0],
                    help="moves of the centre along x and y, in cells (0.25: a quarter cell)")
    ap.add_argument("--algo", choices=["AUTO", "STABLE", "NON"], help="[contact] algo_lagr (default: the case's)")
    a = ap.parse_args()
    scratch = fresh_scratch(a.scratch)
    text = TEMPLATE.read_text()
    jobs = []
    for cell in a.cells:
        for n in a.n:
            for radius in a.radius:
                for shift in a.shift:
                    name = f"{cell.lower()}_n{n}_r{radius}" + (f"_s{shift}" if shift else "")
                    toml = scratch / f"{name}.toml"
                    toml.write_text(variant(text, cell, n, radius, a.algo, shift))
                    jobs.append(dict(name=name, cell=cell, n=n, radius=radius, toml=toml, out=scratch / name))
    rows, total = run_all(jobs, a.slots, a.options)
    head = ("| variant | converged | Newton | threshold it. | forced loops | hand-overs | dof conditions | "
            "min point gap (m) | s |")
    lines = [f"`python bench/inclusion_family.py {' '.join(sys.argv[1:])}`: {len(rows)} runs in {total:.0f} s",
             "", head, "|" + "---|" * 9]
    for r in rows:
        c, g = r.get("conditions"), r.get("min_gap")
        lines.append(f"| {r['name']} | {'yes' if r['converged'] else 'NO'} | {r.get('newton', '-')} | "
                     f"{r.get('threshold', '-')} | {r.get('forced', '-')} | {r.get('guards', '-')} | "
                     f"{'-' if c is None else f'{c:.1e}'} | {'-' if g is None else f'{g:.1e}'} | {r['seconds']} |")
    for cell in a.cells:
        sub = [r for r in rows if r["cell"] == cell]
        ok = [r for r in sub if r["converged"]]
        lines.append("")
        lines.append(f"{cell}: {len(ok)} / {len(sub)} converged; "
                     f"{sum(1 for r in ok if (r.get('newton') or 0) <= a.limit)} within {a.limit} Newton "
                     f"iterations; {sum(1 for r in sub if r.get('forced'))} with forced status loops; "
                     f"Newton iterations over all runs {sum(r.get('newton') or 0 for r in sub)}")
    if len(a.n) > 1:
        lines += refinement(rows, a.cells)
    write_results(a.name, lines, rows)


if __name__ == "__main__":
    main()
