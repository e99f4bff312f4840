"""How far the SSNV509 multipliers are from the best their space can do.

    python bench/multiplier_limit.py                 # the four SSNV509 cases
    python bench/multiplier_limit.py cases/x.toml    # any case with [reference] LAGS_C, LAGS_F1

For each case: the largest pointwise errors of the computed LAGS_C and LAGS_F1
over the interface points, and those of the L2 projections of the exact fields
onto (a) the multiplier space the run uses and (b) the raw vertex space
(``algo_lagr = "NON"``, all vertices of the cut cells, not unique).  A Galerkin
multiplier is at best about the projection, so (a) is the floor of the method
on that mesh.  Prints a Markdown table.
"""
import dataclasses
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from xfemcontact._petsc import PETSc  # noqa: E402  (sets PETSC_DIR, starts PETSc)
from xfemcontact.case import load_case  # noqa: E402
from xfemcontact.model import Model  # noqa: E402
from xfemcontact.post.projection import best_errors  # noqa: E402

CASES = [ROOT / "cases" / f"{n}.toml" for n in ("ssnv509a", "ssnv509a_med", "ssnv509b", "ssnv509b_refined")]


def computed_errors(model, ref):
    from mpi4py import MPI

    v = model.interface_values()
    mpi = model.comm.tompi4py()
    return [mpi.allreduce(float(np.abs(v[f] - ref[f](x=v["x"], y=v["y"])).max(initial=0.0)), op=MPI.MAX)
            for f in ("LAGS_C", "LAGS_F1")]


def main(paths):
    rows = []
    for path in paths:
        case = load_case(path)
        ref = case.reference
        model = Model(case)
        iters = model.solve()
        if iters <= 0:
            raise SystemExit(f"{path}: no convergence")
        got = computed_errors(model, ref)
        space = best_errors(model, ref["LAGS_C"], ref["LAGS_F1"])
        raw_case = dataclasses.replace(case, contact=dataclasses.replace(case.contact, algo_lagr="NON"))
        raw = best_errors(Model(raw_case), ref["LAGS_C"], ref["LAGS_F1"])
        rows.append((pathlib.Path(path).stem, model.mesh.element.name, got, space, raw))
    if PETSc.COMM_WORLD.rank == 0:
        print("| case | cells | computed LAGS_C / LAGS_F1 | L2-best in its space | L2-best in the raw vertex space |")
        print("|---|---|---|---|---|")
        for name, cell, got, space, raw in rows:
            print(f"| {name} | {cell} | {got[0]:.2e} / {got[1]:.2e} | {space['LAGS_C']:.2e} / "
                  f"{space['LAGS_F1']:.2e} | {raw['LAGS_C']:.2e} / {raw['LAGS_F1']:.2e} |")


if __name__ == "__main__":
    main(sys.argv[1:] or CASES)
