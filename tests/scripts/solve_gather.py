"""Solve a case (no interface needed) and save the nodal displacements on rank 0.

    python tests/scripts/solve_gather.py CASE.toml OUT.npz      (also under mpirun)

OUT.npz holds ``ids`` (input node indices), ``x``, ``u`` (n, 2), ``rank`` (owner of
every node) and ``size`` (number of processes), sorted by node id.
"""
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))

import numpy as np  # noqa: E402

from xfemcontact._petsc import PETSc  # noqa: E402
from xfemcontact.case import load_case  # noqa: E402
from xfemcontact.model import Model  # noqa: E402
from xfemcontact.post.gather import gather_nodes  # noqa: E402


def main(case_path, out):
    comm = PETSc.COMM_WORLD
    model = Model(load_case(case_path))
    reason = model.solve()
    if reason <= 0:
        raise SystemExit(f"rank {comm.rank}: no convergence (SNES reason {reason})")
    u = model.displacement()
    n = len(model.mesh.x)
    gathered = gather_nodes(model.mesh, u=u, rank=np.full(n, comm.rank))
    if comm.rank == 0:
        ids, x, data = gathered
        np.savez(out, ids=ids, x=x, u=data["u"], rank=data["rank"], size=comm.size)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
