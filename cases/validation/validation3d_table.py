"""The 3-D validation cases against their closed forms, and several processes against one.

    .venv/bin/python cases/validation/validation3d_table.py                # 1 process
    .venv/bin/python cases/validation/validation3d_table.py --np 2 3 4     # and 2, 3, 4 vs 1
    .venv/bin/python cases/validation/validation3d_table.py ssnv201a_like_hexa20   # some cases

Runs each case of cases/validation (into a temporary folder) and prints one markdown row
per case: cells, dofs, the largest |computed - closed form| over the interface points and
every instant of LAGS_C (relative to the largest |LAGS_C| of the closed form; in Pa where
the closed form is 0: an interface open throughout), LAGS_F1,
LAGS_F2, gap and slip (m) -- the [reference] formulas of the case, those it has -- the
Newton iterations (all steps), the wall time of the run (results.json timings.total) and
its tests.  With ``--np``, the largest difference of the same interface fields between P
processes and one, over every instant (LAGS_C on the same scale as its error).
"""
import argparse
import pathlib
import sys
import tempfile

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[1]
CASES = ["ssnv182a_like_hexa20", "ssnv182a_like_tetra10", "ssnv182b_like_hexa20", "ssnv182b_like_tetra10",
         "ssnv182c_like_hexa20", "ssnv182c_like_tetra10", "ssnv186e_like_hexa20", "ssnv186e_like_tetra10",
         "ssnv186e_like_jittered_tetra10", "ssnv201a_like_hexa20", "ssnv201a_like_tetra10",
         "ssnv201b_like_hexa20", "ssnv201b_like_tetra10", "ssnv195c_lower_like_hexa20",
         "ssnv195c_lower_like_tetra10", "ssnv195c_upper_like_hexa20", "ssnv195c_upper_like_tetra10",
         "history_shear3d_hexa20",
         "history_reclose3d_tetra10", "history_turn3d_hexa20", "history_incline_growing3d_tetra10"]
FIELDS = ("LAGS_C", "LAGS_F1", "LAGS_F2", "gap", "slip")

sys.path.insert(0, str(HERE))
from history_table import run  # noqa: E402  (runs a case of this folder, on np_ processes)


def errors(case, res):
    """{field: largest error over the steps} for the fields with a reference formula
    (LAGS_C relative to the largest |LAGS_C| of the closed form over the steps; in Pa where
    that is 0, an interface open at every step), and that scale under the key "scale"."""
    from xfemcontact.case import load_case

    spec = load_case(HERE / f"{case}.toml")
    out, scale = {}, 0.0
    for step in res["steps"]:
        itf = step["interface"]
        x, y, z = (np.array(itf[c]) for c in ("x", "y", "z"))
        ref = spec.reference_at(step["inst"])
        for f in FIELDS:
            if f in ref:
                exact = np.broadcast_to(ref[f](x=x, y=y, z=z), x.shape)
                out[f] = max(out.get(f, 0.0), float(np.abs(np.array(itf[f]) - exact).max()))
                if f == "LAGS_C":
                    scale = max(scale, float(np.abs(exact).max()))
    if "LAGS_C" in out:
        out["LAGS_C"] /= scale or 1.0
    out["scale"] = scale or 1.0
    return out


def differences(a, b, scale):
    """{field: largest |a - b| over the steps} (LAGS_C divided by ``scale``: the closed
    form's, :func:`errors`)."""
    assert [s["inst"] for s in a["steps"]] == [s["inst"] for s in b["steps"]]
    out = {}
    for x, y in zip(a["steps"], b["steps"]):
        for f in FIELDS:
            u, v = np.array(x["interface"][f]), np.array(y["interface"][f])
            out[f] = max(out.get(f, 0.0), float(np.abs(u - v).max()))
    out["LAGS_C"] /= scale
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--np", type=int, nargs="*", default=[], help="process counts compared with 1")
    parser.add_argument("cases", nargs="*", default=CASES)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        print("| case | cells | dofs | instants | LAGS_C (rel.) | LAGS_F1 | LAGS_F2 | gap (m) | slip (m) | "
              "Newton | time (s) | tests |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        one, scales = {}, {}
        for case in args.cases:
            r = one[case] = run(case, tmp / case)
            e = errors(case, r)
            scales[case] = e.pop("scale")
            ok = sum(t["ok"] for t in r["tests"])
            newton = sum(s["iterations"]["newton"] for s in r["steps"])
            cells = f"{r['mesh']['cells']} {r['mesh']['cell_type']}"
            print(f"| `{case}` | {cells} | {r['dofs']['total']} | {len(r['steps'])} | "
                  + " | ".join(f"{e[f]:.1e}" if f in e else "" for f in FIELDS)
                  + f" | {newton} | {r['timings']['total']:.2f} | {ok}/{len(r['tests'])} OK |")
        if args.np:
            print()
            print("| case | processes | " + " | ".join(FIELDS) + " | time (s) |")
            print("|---|---|" + "---|" * len(FIELDS) + "---|")
            for case in args.cases:
                for n in args.np:
                    res = run(case, tmp / f"{case}-{n}", n)
                    d = differences(one[case], res, scales[case])
                    print(f"| `{case}` | {n} | " + " | ".join(f"{d[f]:.1e}" for f in FIELDS)
                          + f" | {res['timings']['total']:.2f} |")


if __name__ == "__main__":
    main()
