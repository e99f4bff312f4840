"""Benchmark series: SSNV509 geometry on N x N QUAD8 and TRIA6 meshes, 1 and 2 processes.

    python bench/run_series.py                       # N = 20 ... 320, QUAD8 + TRIA6, 1 and 2 processes
    python bench/run_series.py --sizes 640 --procs 1 # one more point
    python bench/run_series.py --extra -xfc_friction_unknown traction
    python bench/run_series.py --sizes 320 --repeat 5   # 5 runs per point, interleaved

With ``--repeat K`` every point is run K times, the process counts taking turns
(1, 2, 1, 2, ...) so that a slow spell of the machine hits both; each row is the
run of median wall time, with the spread (min - max) and, per mesh, the speed-up
of two processes over one from the medians.

Each run is the command line on a generated case (plots off), so the figures are
what a user gets.  Per run: dofs by kind, cut cells, loop iterations, wall time
of every phase, the MUMPS analysis / factorisation / solve times (PETSc events),
peak memory per process, and the start-up overhead (process wall time minus the
run's own total).  Output in bench/results/: series.json, series.md, series.png.
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUT = ROOT / "bench" / "results"
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
           PETSC_DIR=os.environ.get("PETSC_DIR", "/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real"))

#: GetFEM 5.4 on this kind of machine, same discretisation (SPEC.md section 4)
GETFEM = {("QUAD8", 20): (3128, 0.24, 69), ("QUAD8", 80): (41208, 3.9, 295), ("QUAD8", 320): (625584, 56.6, 4052),
          ("TRIA6", 20): (3920, 0.32, 68), ("TRIA6", 80): (54000, 4.2, 278), ("TRIA6", 320): (830352, 49.2, 3871)}

PHASES = ("mesh", "checks", "levelset", "layout", "assembly", "solve", "post", "output")


#: the SSNV509 modelisation of each cell type (its test tolerances are those of that modelisation)
BASE_CASE = {"QUAD8": "ssnv509a.toml", "TRIA6": "ssnv509b.toml"}


def case_text(cell, n):
    base = (ROOT / "cases" / BASE_CASE[cell]).read_text()
    head, tail = base.split("[mesh]", 1)
    tail = tail.split("\n", 2)[2]          # drop the original mesh line
    mesh = f'[mesh]\nrectangle = {{ nx = {n}, ny = {n}, x = [0.0, 10.0], y = [0.0, 10.0], cell = "{cell}" }}\n'
    return head + mesh + tail + "\n[output]\nplots = false\n"


def run_one(cell, n, procs, extra, workdir):
    case = workdir / f"{cell}_{n}.toml"
    case.write_text(case_text(cell, n))
    out = workdir / f"out_{cell}_{n}_{procs}"
    cmd = [sys.executable, "-m", "xfemcontact", "run", str(case), "-o", str(out), "--overwrite", *extra]
    if procs > 1:
        cmd = ["mpirun", "-n", str(procs), "--oversubscribe"] + cmd
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=ENV, timeout=3600, cwd=ROOT)
    wall = time.perf_counter() - t0
    if not (out / "results.json").exists():
        return {"cell": cell, "n": n, "procs": procs, "error": (p.stderr or p.stdout)[-500:]}
    r = json.loads((out / "results.json").read_text())
    ev = r.get("solver_events", {})
    t = r["timings"]
    analysis = sum(ev.get(k, {}).get("time", 0.0) for k in ("MatLUFactorSym", "MatCholFctrSym"))
    factor = sum(ev.get(k, {}).get("time", 0.0) for k in ("MatLUFactorNum", "MatCholFctrNum"))
    nfact = sum(ev.get(k, {}).get("count", 0) for k in ("MatLUFactorNum", "MatCholFctrNum"))
    solves = ev.get("MatSolve", {}).get("time", 0.0)
    mumps = analysis + factor + solves
    row = {
        "cell": cell, "n": n, "procs": procs, "dofs": r["dofs"],
        "cut_cells": (r.get("geometry") or {}).get("cut_cells"),
        "iterations": r["iterations"], "factorisations": nfact,
        "phases": {k: t.get(k, 0.0) for k in PHASES},
        "mumps": {"analysis": analysis, "factorisation": factor, "solve": solves},
        "total": t.get("total", 0.0), "wall": wall, "startup": wall - t.get("total", 0.0),
        "other_share": 1.0 - mumps / wall if wall else None,
        "peak_mb": r["memory"]["peak_mb_per_process"],
        "ok": all(x["ok"] for x in r["tests"]), "exit": p.returncode,
        "partition": r.get("partition"),
    }
    return row


def markdown(rows):
    lines = ["| cell | N | P | dofs (u / H / C / F1) | cut | fact. | mesh | lset | layout | assem | "
             "analysis | factor | solve | post+out | total wall | other % | peak MB/proc | tests | GetFEM s / MB |",
             "|" + "---|" * 19]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['cell']} | {r['n']} | {r['procs']} | error: {r['error'][:60]} |" + " |" * 15)
            continue
        d, p, m = r["dofs"], r["phases"], r["mumps"]
        g = GETFEM.get((r["cell"], r["n"]))
        lines.append(
            f"| {r['cell']} | {r['n']} | {r['procs']} | {d['total']} ({d['displacement']} / {d['heaviside']} / "
            f"{d['LAGS_C']} / {d['LAGS_F1']}) | {r['cut_cells']} | {r['factorisations']} | {p['mesh']:.2f} | "
            f"{p['levelset']:.2f} | {p['layout']:.2f} | {p['assembly']:.2f} | {m['analysis']:.2f} | "
            f"{m['factorisation']:.2f} | {m['solve']:.2f} | {p['post'] + p['output']:.2f} | {r['wall']:.2f} | "
            f"{100 * r['other_share']:.0f} | {max(r['peak_mb']):.0f} | {'OK' if r['ok'] else 'NOOK'} | "
            f"{f'{g[1]} / {g[2]}' if g else ''} |")
    return "\n".join(lines) + "\n"


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(13, 5), sharey=True)
    for ax, cell in zip(axes, ("QUAD8", "TRIA6")):
        sel = [r for r in rows if r["cell"] == cell and r["procs"] == 1 and "error" not in r]
        if not sel:
            continue
        dofs = [r["dofs"]["total"] for r in sel]
        series = {
            "mesh + level set + layout": [r["phases"]["mesh"] + r["phases"]["checks"] + r["phases"]["levelset"]
                                          + r["phases"]["layout"] for r in sel],
            "assembly": [r["phases"]["assembly"] for r in sel],
            "MUMPS analysis": [r["mumps"]["analysis"] for r in sel],
            "MUMPS factorisation": [r["mumps"]["factorisation"] for r in sel],
            "MUMPS solve": [r["mumps"]["solve"] for r in sel],
            "post-processing + output": [r["phases"]["post"] + r["phases"]["output"] for r in sel],
            "total wall": [r["wall"] for r in sel],
        }
        for name, ys in series.items():
            ax.loglog(dofs, [max(y, 1e-3) for y in ys], "o-" if name != "total wall" else "k--", label=name)
        g = [(GETFEM[cell, n][0], GETFEM[cell, n][1]) for n in (20, 80, 320)]
        ax.loglog(*zip(*g), "rs:", label="GetFEM 5.4 total (SPEC)")
        ax.set_xlabel("dofs")
        ax.set_title(f"SSNV509 geometry, {cell}, 1 process")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("wall time (s)")
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", nargs="+", default=["QUAD8", "TRIA6"])
    ap.add_argument("--sizes", nargs="+", type=int, default=[20, 40, 80, 160, 320])
    ap.add_argument("--procs", nargs="+", type=int, default=[1, 2])
    ap.add_argument("--name", default="series")
    ap.add_argument("--repeat", type=int, default=1, help="runs per point (median reported)")
    ap.add_argument("--extra", nargs=argparse.REMAINDER, default=[], help="PETSc options for every run")
    args = ap.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    work = OUT / "runs"
    work.mkdir(exist_ok=True)
    rows = []
    for cell in args.cells:
        for n in args.sizes:
            runs = {procs: [] for procs in args.procs}
            for _ in range(args.repeat):
                for procs in args.procs:
                    row = run_one(cell, n, procs, args.extra, work)
                    runs[procs].append(row)
                    print(f"{cell} N={n} P={procs}: {brief(row)}", flush=True)
            rows += [median_row(runs[procs]) for procs in args.procs]
    (OUT / f"{args.name}.json").write_text(json.dumps(rows, indent=1))
    (OUT / f"{args.name}.md").write_text(markdown(rows) + speedups(rows))
    plot(rows, OUT / f"{args.name}.png")
    print(markdown(rows) + speedups(rows))


def brief(row):
    if "error" in row:
        return "error"
    return (f"{row['dofs']['total']} dofs, wall {row['wall']:.2f} s, factorisations "
            f"{row['factorisations']}, other {100 * row['other_share']:.0f} %, "
            f"peak {max(row['peak_mb']):.0f} MB/proc, tests {'OK' if row['ok'] else 'NOOK'}")


def median_row(runs):
    """The run of median wall time (the lower middle one for an even count), with the
    walls of all runs in ``walls``."""
    good = [r for r in runs if "error" not in r]
    if not good:
        return runs[0]
    good.sort(key=lambda r: r["wall"])
    row = dict(good[(len(good) - 1) // 2])
    row["walls"] = [r["wall"] for r in good]
    return row


def speedups(rows):
    """Markdown lines: wall time of one process over two, per mesh, from the medians."""
    lines = []
    for r1 in rows:
        r2 = next((r for r in rows if r["cell"] == r1["cell"] and r["n"] == r1["n"] and r["procs"] == 2), None)
        if r1["procs"] != 1 or r2 is None or "error" in r1 or "error" in r2:
            continue
        spread = ""
        if len(r1.get("walls", [])) > 1:
            spread = (f" (runs: 1 process {min(r1['walls']):.1f} - {max(r1['walls']):.1f} s, "
                      f"2 processes {min(r2['walls']):.1f} - {max(r2['walls']):.1f} s, "
                      f"{len(r1['walls'])} each)")
        lines.append(f"- {r1['cell']} N = {r1['n']}: 2 processes {r1['wall'] / r2['wall']:.2f} times "
                     f"faster than 1 (median walls {r1['wall']:.2f} / {r2['wall']:.2f} s){spread}")
    return ("\n" + "\n".join(lines) + "\n") if lines else ""


if __name__ == "__main__":
    main()
