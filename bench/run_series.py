"""Benchmark series: SSNV509 geometry on N x N QUAD8 and TRIA6 meshes, or the oedometer of
cases/box_hexa20.toml on N x N x N HEXA20 and TETRA10 boxes; 1 and 2 processes.

    python bench/run_series.py                          # N = 20 ... 320, QUAD8 + TRIA6, 1 and 2 processes
    python bench/run_series.py --cells HEXA20 TETRA10 --sizes 8 12 16 20 --name series3d   # 3-D
    python bench/run_series.py --sizes 320 --repeat 5   # 5 runs per point, interleaved
    python bench/run_series.py --cells QUAD8 --sizes 640 1000 --procs 1 2 --name large
    python bench/run_series.py --sizes 160 320 --repeat 3 --variant before=/tmp/base --name compare
    python bench/run_series.py --extra -xfc_friction_unknown traction

Each run is the command line on a generated case with the default outputs (fields,
interface.csv, the four plots; ``--no-plots`` switches the plots off), so the
figures are what a user gets.  2-D cells (QUAD8, TRIA6): the SSNV509 case of the
cell type on an N x N rectangle of 10 m x 10 m.  3-D cells (HEXA20, TETRA10): the
oedometer of cases/box_hexa20.toml (1 m x 1 m x 2 m block under a pressure on its
top face, sides and bottom on rollers; no interface: X-FEM is 2-D only so far) on an
N x N x N box: about 12 N^3 dofs on HEXA20, 24 N^3 on TETRA10.  With ``--repeat K`` every point is run K times, the
process counts (and variants) taking turns (1, 2, 1, 2, ...) so that a slow spell
of this shared machine hits all of them; each row is the run of median wall time,
with the spread.

``--variant NAME=DIR`` adds the source tree DIR (a checkout or ``git archive`` of
another commit) run the same way, interleaved with this one, for before/after
comparisons in one series.

Per run: dofs by kind, loop iterations, wall time of every phase and output step,
the MUMPS analysis / factorisation / solve times (PETSc events), peak memory per
process and at the end of every phase, process CPU time (user, system: first
touch of memory is system time on this machine), and derived figures:

* ``whole / 1 fact.``: process wall time over one numeric factorisation (the mean
  of the run's factorisations; SSNV509 factorises twice);
* ``outside MUMPS``: wall time minus analysis, factorisations and solves;
* ``output %``: post-processing and output phases over the wall time;
* ``dofs/s``: dofs over wall time.

Output in bench/results/: NAME.json, NAME.md, NAME.png.
"""
import argparse
import json
import os
import pathlib
import resource
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUT = ROOT / "bench" / "results"
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
           PETSC_DIR=os.environ.get("PETSC_DIR", "/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real"))

#: GetFEM 5.4 on this kind of machine, same discretisation: (dofs, wall s, peak MB)
GETFEM = {("QUAD8", 20): (3128, 0.24, 69), ("QUAD8", 80): (41208, 3.9, 295), ("QUAD8", 320): (625584, 56.6, 4052),
          ("TRIA6", 20): (3920, 0.32, 68), ("TRIA6", 80): (54000, 4.2, 278), ("TRIA6", 320): (830352, 49.2, 3871)}

PHASES = ("mesh", "checks", "levelset", "layout", "assembly", "solve", "post", "output")

#: the case of each cell type: 2-D, the SSNV509 modelisation of that cell type (its test
#: tolerances are those of that modelisation); 3-D, the oedometer example (its closed
#: form is linear in x, y, z: exact on both cell types)
BASE_CASE = {"QUAD8": "ssnv509a.toml", "TRIA6": "ssnv509b.toml",
             "HEXA20": "box_hexa20.toml", "TETRA10": "box_hexa20.toml"}
CELLS_3D = ("HEXA20", "TETRA10")


def mesh_line(cell, n):
    """The generated mesh of size N: an N x N rectangle (2-D) or an N x N x N box with the
    extents of the oedometer (3-D)."""
    if cell in CELLS_3D:
        return (f'box = {{ nx = {n}, ny = {n}, nz = {n}, x = [0.0, 1.0], y = [0.0, 1.0], z = [0.0, 2.0], '
                f'cell = "{cell}" }}')
    return f'rectangle = {{ nx = {n}, ny = {n}, x = [0.0, 10.0], y = [0.0, 10.0], cell = "{cell}" }}'


def case_text(cell, n, plots=True):
    """The base case of ``cell`` with its mesh line replaced by :func:`mesh_line`."""
    name = BASE_CASE[cell]
    base = (ROOT / "cases" / name).read_text()
    if cell in CELLS_3D:                   # the base case's title names its own cell type
        base = base.replace("HEXA20", cell)
    head, tail = base.split("[mesh]", 1)
    tail = tail.split("\n", 2)[2]          # drop the original mesh line
    return head + "[mesh]\n" + mesh_line(cell, n) + "\n" + tail + ("" if plots else "\n[output]\nplots = false\n")


def run_one(cell, n, procs, args, workdir, source=None, variant=""):
    case = workdir / f"{cell}_{n}{'' if args.plots else '_noplots'}.toml"
    case.write_text(case_text(cell, n, args.plots))
    out = workdir / f"out_{cell}_{n}_{procs}{'_' + variant if variant else ''}"
    cmd = [sys.executable, "-m", "xfemcontact", "run", str(case), "-o", str(out), "--overwrite", *args.extra]
    if procs > 1:
        cmd = ["mpirun", "-n", str(procs), "--oversubscribe"] + cmd
    env, cwd = dict(ENV), ROOT
    if source is not None:          # another source tree: first on the path, run from there
        env["PYTHONPATH"] = str(source)
        cwd = source
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=args.timeout, cwd=cwd)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    base = {"cell": cell, "n": n, "procs": procs, "variant": variant, "exit": p.returncode, "wall": wall}
    if not (out / "results.json").exists() or p.returncode not in (0, 1):
        return dict(base, error=(p.stderr or p.stdout).strip()[-500:])
    r = json.loads((out / "results.json").read_text())
    ev = r.get("solver_events", {})
    t = r["timings"]
    analysis = sum(ev.get(k, {}).get("time", 0.0) for k in ("MatLUFactorSym", "MatCholFctrSym"))
    factor = sum(ev.get(k, {}).get("time", 0.0) for k in ("MatLUFactorNum", "MatCholFctrNum"))
    nfact = sum(ev.get(k, {}).get("count", 0) for k in ("MatLUFactorNum", "MatCholFctrNum"))
    solves = ev.get("MatSolve", {}).get("time", 0.0)
    mumps = analysis + factor + solves
    one = factor / nfact if nfact else None
    mem = r["memory"]
    return dict(
        base, dofs=r["dofs"], cut_cells=(r.get("geometry") or {}).get("cut_cells"),
        iterations=r["iterations"], factorisations=nfact,
        phases={k: t.get(k, 0.0) for k in PHASES}, steps=r.get("timing_steps", {}),
        mumps={"analysis": analysis, "factorisation": factor, "solve": solves, "one_factorisation": one},
        total=t.get("total", 0.0), startup=wall - t.get("total", 0.0),
        cpu={"user": after.ru_utime - before.ru_utime, "system": after.ru_stime - before.ru_stime},
        outside_mumps=wall - mumps,
        whole_over_one=wall / one if one else None,
        output_share=(t.get("post", 0.0) + t.get("output", 0.0)) / wall,
        dofs_per_s=r["dofs"]["total"] / wall,
        peak_mb=mem["peak_mb_per_process"], phase_memory=mem.get("phases"),
        mumps_info=(r.get("linear_solver") or {}).get("mumps"),
        ok=all(x["ok"] for x in r["tests"]), partition=r.get("partition"),
        estimate_mb=(r.get("resources") or {}).get("estimate_mb"))


def _f(v, fmt):
    return "-" if v is None else format(v, fmt)


def markdown(rows):
    head = ("| cell | N | P | variant | dofs | fact. | one fact. s | analysis s | wall s | whole / 1 fact. | "
            "outside MUMPS s | output s (%) | peak MB/proc | dofs/s | CPU user / sys s | tests |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        label = f"| {r['cell']} | {r['n']} | {r['procs']} | {r.get('variant') or '-'} |"
        if "error" in r:
            lines.append(label + f" error (exit {r['exit']}): {r['error'][-120:]} |" + " |" * 11)
            continue
        m, p = r["mumps"], r["phases"]
        out = p["post"] + p["output"]
        spread = f" ({min(r['walls']):.1f}-{max(r['walls']):.1f})" if len(r.get("walls", [])) > 1 else ""
        lines.append(
            label + f" {r['dofs']['total']} | {r['factorisations']} | {_f(m['one_factorisation'], '.2f')} | "
            f"{m['analysis']:.2f} | {r['wall']:.2f}{spread} | {_f(r['whole_over_one'], '.2f')} | "
            f"{r['outside_mumps']:.2f} | {out:.2f} ({100 * r['output_share']:.0f}) | "
            f"{' / '.join(f'{x:.0f}' for x in r['peak_mb'])} | {r['dofs_per_s']:.0f} | "
            f"{r['cpu']['user']:.1f} / {r['cpu']['system']:.1f} | {'OK' if r['ok'] else 'NOOK'} |")
    return "\n".join(lines) + "\n"


def phase_table(rows):
    """Wall time and peak memory (max over processes) at the end of every phase."""
    lines = ["| cell | N | P | variant | " + " | ".join(PHASES) + " | startup |",
             "|" + "---|" * (len(PHASES) + 5)]
    for r in rows:
        if "error" in r:
            continue
        pm = r.get("phase_memory") or {}
        cells = []
        for k in PHASES:
            mb = max(x for x in pm[k]["peak_mb"] if x is not None) if k in pm else None
            cells.append(f"{r['phases'][k]:.2f} s / {_f(mb, '.0f')} MB")
        lines.append(f"| {r['cell']} | {r['n']} | {r['procs']} | {r.get('variant') or '-'} | "
                     + " | ".join(cells) + f" | {r['startup']:.2f} s |")
    return "\n".join(lines) + "\n"


def step_table(rows):
    """Wall time of the output steps."""
    names = sorted({k for r in rows if "error" not in r for k in r.get("steps", {})})
    if not names:
        return ""
    lines = ["| cell | N | P | variant | " + " | ".join(n.split(":")[-1] for n in names) + " |",
             "|" + "---|" * (len(names) + 4)]
    for r in rows:
        if "error" in r:
            continue
        lines.append(f"| {r['cell']} | {r['n']} | {r['procs']} | {r.get('variant') or '-'} | "
                     + " | ".join(f"{r['steps'].get(k, 0.0):.2f}" for k in names) + " |")
    return "\n".join(lines) + "\n"


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cells = list(dict.fromkeys(r["cell"] for r in rows)) or ["QUAD8"]
    panels = [c for c in ("QUAD8", "TRIA6") if c in cells or not set(cells) & set(CELLS_3D)] + \
        [c for c in CELLS_3D if c in cells]
    fig, axes = plt.subplots(1, len(panels), figsize=(6.5 * len(panels), 5), sharey=True, squeeze=False)
    axes = axes[0]
    for ax, cell in zip(axes, panels):
        sel = [r for r in rows if r["cell"] == cell and r["procs"] == 1 and "error" not in r
               and not r.get("variant")]
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
        g = [(GETFEM[cell, n][0], GETFEM[cell, n][1]) for n in (20, 80, 320) if (cell, n) in GETFEM]
        if g:
            ax.loglog(*zip(*g), "rs:", label="GetFEM 5.4 total")
        ax.set_xlabel("dofs")
        ax.set_title(f"{'oedometer box' if cell in CELLS_3D else 'SSNV509 geometry'}, {cell}, 1 process")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("wall time (s)")
    axes[-1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", nargs="+", default=["QUAD8", "TRIA6"])
    ap.add_argument("--sizes", nargs="+", type=int, default=None,
                    help="N: cells per side (default 20 40 80 160 320; 3-D cells only: 8 12 16 20)")
    ap.add_argument("--procs", nargs="+", type=int, default=[1, 2])
    ap.add_argument("--name", default="series")
    ap.add_argument("--repeat", type=int, default=1, help="runs per point (median reported)")
    ap.add_argument("--no-plots", dest="plots", action="store_false", help="cases with [output] plots = false")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME=DIR",
                    help="also run the source tree DIR, interleaved (repeatable)")
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds per run")
    ap.add_argument("--extra", nargs=argparse.REMAINDER, default=[], help="PETSc options for every run")
    args = ap.parse_args()
    if args.sizes is None:
        args.sizes = [8, 12, 16, 20] if set(args.cells) <= set(CELLS_3D) else [20, 40, 80, 160, 320]
    variants = [("", None)] + [(v.split("=", 1)[0], pathlib.Path(v.split("=", 1)[1]).resolve()) for v in args.variant]
    OUT.mkdir(parents=True, exist_ok=True)
    work = OUT / "runs"
    work.mkdir(exist_ok=True)
    rows = []
    for cell in args.cells:
        for n in args.sizes:
            runs = {(procs, name): [] for procs in args.procs for name, _ in variants}
            for _ in range(args.repeat):
                for procs in args.procs:
                    for name, source in variants:
                        row = run_one(cell, n, procs, args, work, source, name)
                        runs[procs, name].append(row)
                        print(f"{cell} N={n} P={procs}{' ' + name if name else ''}: {brief(row)}", flush=True)
            rows += [median_row(runs[key]) for key in runs]
            (OUT / f"{args.name}.json").write_text(json.dumps(rows, indent=1))
    text = (markdown(rows) + speedups(rows) + "\nWall time and peak memory at the end of each phase:\n\n"
            + phase_table(rows) + "\nOutput steps (s):\n\n" + step_table(rows))
    (OUT / f"{args.name}.md").write_text(text)
    plot(rows, OUT / f"{args.name}.png")
    print(text)


def brief(row):
    if "error" in row:
        return f"error (exit {row['exit']}): {row['error'][-200:]}"
    return (f"{row['dofs']['total']} dofs, wall {row['wall']:.2f} s, whole/1 fact. "
            f"{_f(row['whole_over_one'], '.2f')}, outside MUMPS {row['outside_mumps']:.2f} s, output "
            f"{100 * row['output_share']:.0f} %, peak {max(row['peak_mb']):.0f} MB/proc, "
            f"tests {'OK' if row['ok'] else 'NOOK'}")


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
    """Markdown lines: wall time and memory per process of one process over two, per mesh."""
    lines = []
    for r1 in rows:
        r2 = next((r for r in rows if r["cell"] == r1["cell"] and r["n"] == r1["n"] and r["procs"] == 2
                   and r.get("variant") == r1.get("variant")), None)
        if r1["procs"] != 1 or r2 is None or "error" in r1 or "error" in r2:
            continue
        spread = ""
        if len(r1.get("walls", [])) > 1:
            spread = (f" (runs: 1 process {min(r1['walls']):.1f} - {max(r1['walls']):.1f} s, "
                      f"2 processes {min(r2['walls']):.1f} - {max(r2['walls']):.1f} s, "
                      f"{len(r1['walls'])} each)")
        m1, m2 = r1["mumps"], r2["mumps"]
        mumps1 = m1["analysis"] + m1["factorisation"] + m1["solve"]
        mumps2 = m2["analysis"] + m2["factorisation"] + m2["solve"]
        lines.append(f"- {r1['cell']} N = {r1['n']}{' ' + r1['variant'] if r1.get('variant') else ''}: "
                     f"2 processes {r1['wall'] / r2['wall']:.2f} times faster than 1 (median walls "
                     f"{r1['wall']:.2f} / {r2['wall']:.2f} s; MUMPS alone {mumps1:.2f} / {mumps2:.2f} s), "
                     f"peak memory per process {max(r1['peak_mb']):.0f} -> {max(r2['peak_mb']):.0f} MB "
                     f"({max(r1['peak_mb']) / max(r2['peak_mb']):.2f} times less){spread}")
    return ("\n" + "\n".join(lines) + "\n") if lines else ""


if __name__ == "__main__":
    main()
