"""A straight interface sliding past one vertex: errors against the closed form as the
interface nears the vertex (readjustment rule 2, xfemcontact/xfem/levelset.py).

    python bench/vertex_fit.py                              # QUAD8 and TRIA6, -10 and 30 degrees
    python bench/vertex_fit.py --fracs 1e-7 1e-9 --meshes q8s

The case is the sliding campaign's ``limit-D_q8s_a-10_vfit`` (bench/campaign.py: a 2 m x 2 m
plate, 10 x 10 cells of 0.2 m, at the Coulomb limit under 100 Pa, slip 8e-4 m imposed by
the boundary data), its line moved to ``frac x h`` above the vertex (1, 1) and turned to
each angle.  Prints, per run: the exit code, Newton iterations, vertices fitted, the errors of
LAGS_C relative to the pressure and of the gap and slip relative to the slip (the case's
MAX_ERROR tests: the exact fields lie in the discrete space).
"""
import argparse
import dataclasses
import json
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
import campaign  # noqa: E402


def run(c, scratch):
    """Run case ``c`` (a campaign.Line) in ``scratch``; returns (exit code, results or None, errors)."""
    case = scratch / "case.toml"
    case.write_text(campaign.case_text(c, meshes=str(ROOT / "cases" / "meshes")))
    out = scratch / "out"
    cmd = [sys.executable, "-m", "xfemcontact", "run", str(case), "-o", str(out), "--overwrite", "-q"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=campaign.ENV, cwd=ROOT)
    errors = {}
    for line in proc.stdout.splitlines():
        words = line.split()
        if len(words) > 3 and words[1] == "MAX_ERROR":
            errors[words[2]] = float(words[3])
    res = json.loads((out / "results.json").read_text()) if (out / "results.json").exists() else None
    return proc.returncode, res, errors


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fracs", type=float, nargs="+",
                    default=[1e-5, 1e-6, 1e-7, 1e-8, 3e-9, 1e-9, 3e-10, 1e-10, 1e-11, 3e-12, 1e-12])
    ap.add_argument("--meshes", nargs="+", default=["q8s", "t6s"])
    ap.add_argument("--angles", type=float, nargs="+", default=[-10.0, 30.0])
    args = ap.parse_args(argv)
    base = next(c for c in campaign.TABLE if c.pos == "vfit")
    print(f"{'mesh':4} {'d / h':>7} {'angle':>5} {'exit':>4} {'Newton':>6} {'fitted':>6} "
          f"{'LAGS_C':>9} {'gap':>9} {'slip':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        for mesh in args.meshes:
            for frac in args.fracs:
                for theta in args.angles:
                    c = dataclasses.replace(base, mesh=mesh, theta=theta,
                                            point=(1.0, campaign._vtx(0.2, frac)))
                    rc, res, err = run(c, pathlib.Path(tmp))
                    newton = res["iterations"]["newton"] if res else "-"
                    fitted = res["geometry"]["readjusted"]["fitted_vertices"] if res else "-"
                    rel = [err.get("LAGS_C", float("nan")) / c.p] + [err.get(k, float("nan")) / abs(c.s)
                                                                      for k in ("gap", "slip")]
                    print(f"{mesh:4} {frac:7.0e} {theta:5.0f} {rc:4d} {newton!s:>6} {fitted!s:>6} "
                          + " ".join(f"{v:9.1e}" for v in rel), flush=True)


if __name__ == "__main__":
    main()
