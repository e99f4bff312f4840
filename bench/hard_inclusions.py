"""Floating inclusions of other shapes, loads and friction coefficients: does Newton get there?

    .venv/bin/python bench/hard_inclusions.py                 # 48 runs, about 1 minute on 2 cores
    .venv/bin/python bench/hard_inclusions.py -- -xfc_coarse_start NONE

The template of ``bench/inclusion_family.py`` (an inclusion held by contact and Coulomb
friction alone in a 10 m plate clamped at its bottom and loaded on its other edges by the
tractions of a uniform stress), on 24 x 24 QUAD8 and TRIA6, with three interfaces (the circle
R = 2.3 m, an ellipse of half-axes 2.8 and 1.9 m, the same tilted by 37 degrees with half-axes
2.8 and 1.8 m), four stress states (sigma_xx, sigma_yy, sigma_xy in Pa: mixed -100, 20, 30;
compression and shear -100, -50, 40; opening -100, 50, 10; shear -60, -60, 45) and mu = 0.2
and 0.6: open, stick and slip zones side by side, and bodies whose rotation friction alone
holds.  None of them has a closed form; each run is judged on the law: convergence, the
conditions at the dofs (results.json ``conditions``) and the point values between them.

Printed per run: converged, Newton iterations over the run (the coarse start's included, and
given apart), threshold iterations, hand-overs of the line search, forced status loops, the
largest condition violation at the dofs, max LAGS_C (Pa), max |LAGS_F1| and the smallest
point gap (m; displacements about 1e-3 m).  Written to ``bench/results/<name>.md`` and ``.json``.
"""
import argparse
import importlib.util
import itertools
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("inclusion_family", ROOT / "bench" / "inclusion_family.py")
family = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(family)

SHAPES = {"circle": "(x-xc)**2 + (y-yc)**2 - 2.3**2",
          "ellipse": "((x-xc)/2.8)**2 + ((y-yc)/1.9)**2 - 1",
          "tilted": "((0.8*(x-xc)+0.6*(y-yc))/2.8)**2 + ((-0.6*(x-xc)+0.8*(y-yc))/1.8)**2 - 1"}
LOADS = {"mixed": (-100.0, 20.0, 30.0), "compr_shear": (-100.0, -50.0, 40.0),
         "open": (-100.0, 50.0, 10.0), "shear": (-60.0, -60.0, 45.0)}
MUS = (0.2, 0.6)


def variant(cell: str, shape: str, load: str, mu: float, n: int = 24) -> str:
    """The family's template on n x n ``cell`` with the interface ``shape``, the stress state
    ``load`` and Coulomb's coefficient ``mu``."""
    text = family.variant(family.TEMPLATE.read_text(), cell, n, 2.3)
    text, k = re.subn(re.escape('"(x-xc)**2 + (y-yc)**2 - 2.3**2"'), f'"{SHAPES[shape]}"', text)
    counts = [k]
    for key, value in zip(("sxx", "syy", "sxy", "coulomb"), (*LOADS[load], mu)):
        text, k = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
        counts.append(k)
    if counts != [1] * 5:
        raise SystemExit(f"error: {family.TEMPLATE}: the template changed; update bench/hard_inclusions.py")
    return text


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    family.add_common_arguments(ap, "hard_inclusions")
    ap.add_argument("--n", type=int, default=24, help="cells per side")
    a = ap.parse_args()
    scratch = family.fresh_scratch(a.scratch)
    jobs = []
    for shape, load, mu, cell in itertools.product(SHAPES, LOADS, MUS, a.cells):
        name = f"{shape}_{load}_mu{mu}_{cell.lower()}"
        toml = scratch / f"{name}.toml"
        toml.write_text(variant(cell, shape, load, mu, a.n))
        jobs.append(dict(name=name, cell=cell, n=a.n, radius=None, toml=toml, out=scratch / name))
    rows, total = family.run_all(jobs, a.slots, ["--no-plots", *a.options])
    lines = [f"`python bench/hard_inclusions.py {' '.join(sys.argv[1:])}`: {len(rows)} runs in {total:.0f} s", "",
             "| variant | converged | Newton (coarse start) | threshold it. | hand-overs | forced loops | "
             "dof conditions | max LAGS_C (Pa) | max abs LAGS_F1 | min point gap (m) |",
             "|" + "---|" * 10]
    fmt = (lambda v, f: "-" if v is None else format(v, f))
    for r in rows:
        coarse = f" ({r['coarse']}{'' if r.get('coarse_used') else ', dropped'})" if r.get("coarse") is not None else ""
        lines.append(f"| {r['name']} | {'yes' if r.get('converged') else 'NO'} | {r.get('newton', '-')}{coarse} | "
                     f"{r.get('threshold', '-')} | {r.get('guards', '-')} | {r.get('forced', '-')} | "
                     f"{fmt(r.get('conditions'), '.1e')} | {fmt(r.get('max_lags_c'), '.1e')} | "
                     f"{fmt(r.get('max_lags_f1'), '.13f')} | {fmt(r.get('min_gap'), '.1e')} |")
    ok = [r for r in rows if r.get("converged")]
    newton = sorted(r.get("newton") or 0 for r in ok)
    lines += ["", f"{len(ok)} / {len(rows)} converged; {sum(1 for n in newton if n <= a.limit)} within {a.limit} "
              f"Newton iterations (median {newton[len(newton) // 2] if newton else '-'}, most {newton[-1] if newton else '-'}); "
              f"{sum(1 for r in rows if r.get('forced'))} with forced status loops; Newton iterations over all runs "
              f"{sum(r.get('newton') or 0 for r in rows)}; worst condition at the dofs "
              f"{max((r.get('conditions') or 0.0 for r in ok), default=0.0):.1e}"]
    family.write_results(a.name, lines, rows)


if __name__ == "__main__":
    main()
