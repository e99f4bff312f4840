"""Errors of the load-history validation cases at every instant, against their closed forms.

    .venv/bin/python cases/validation/history_table.py            # 1 process, markdown table
    .venv/bin/python cases/validation/history_table.py --np 2 3   # and 2, 3 processes vs 1

Runs each case (into a temporary folder) and prints, per case and instant, the largest
|computed - closed form| over the interface points of LAGS_C (Pa), LAGS_F1, slip and gap
(m): the [reference] formulas of the case, at that instant.  With ``--np``, the largest
difference of the same fields between P processes and one, over every instant.
"""
import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[1]
CASES = ["ssnv509_ramp", "ssnv182f_like", "history_shear_cycle", "history_open_reclose", "history_cut"]
FIELDS = ("LAGS_C", "LAGS_F1", "slip", "gap")


def run(case, out, np_=None):
    cmd = [sys.executable, "-m", "xfemcontact", "run", str(HERE / f"{case}.toml"), "-o", str(out), "-q"]
    if np_:
        cmd = ["mpirun", "-n", str(np_), "--oversubscribe"] + cmd
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=env)
    if p.returncode != 0:
        sys.exit(f"{case}: exit code {p.returncode}\n{p.stdout}{p.stderr}")
    return json.loads((out / "results.json").read_text())


def errors(case, res):
    from xfemcontact.case import load_case

    spec = load_case(HERE / f"{case}.toml")
    rows = []
    for step in res["steps"]:
        itf = step["interface"]
        x, y = np.array(itf["x"]), np.array(itf["y"])
        ref = spec.reference_at(step["inst"])
        rows.append((step["inst"], step["level"], [
            float(np.abs(np.array(itf[f]) - np.broadcast_to(ref[f](x=x, y=y), x.shape)).max())
            for f in FIELDS]))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--np", type=int, nargs="*", default=[], help="process counts compared with 1")
    parser.add_argument("cases", nargs="*", default=CASES)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        print("| case | t | LAGS_C (Pa) | LAGS_F1 | slip (m) | gap (m) |")
        print("|---|---|---|---|---|---|")
        one = {}
        for case in args.cases:
            one[case] = run(case, tmp / case)
            for t, level, e in errors(case, one[case]):
                cut = f" (cut, level {level})" if level else ""
                print(f"| `{case}` | {t:g}{cut} | " + " | ".join(f"{v:.1e}" for v in e) + " |")
        if args.np:
            print()
            print("| case | processes | instants | " + " | ".join(FIELDS) + " |")
            print("|---|---|---|" + "---|" * len(FIELDS))
            for case in args.cases:
                for n in args.np:
                    res = run(case, tmp / f"{case}-{n}", n)
                    a, b = one[case]["steps"], res["steps"]
                    assert [s["inst"] for s in a] == [s["inst"] for s in b]
                    d = [max(np.abs(np.array(x["interface"][f]) - np.array(y["interface"][f])).max()
                             for x, y in zip(a, b)) for f in FIELDS]
                    print(f"| `{case}` | {n} | {len(a)} | " + " | ".join(f"{v:.1e}" for v in d) + " |")


if __name__ == "__main__":
    main()
