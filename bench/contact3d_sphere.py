"""Contact in 3-D on a curved interface: a sphere in the unit box under a uniform stress.

    .venv/bin/python bench/contact3d_sphere.py [HEXA20,TETRA10] [4,8,12] [mu]

The sphere of bench/xfem3d_geometry.py (R = 0.3125, centre (0.4689, 0.5311, 0.4693))
is an inclusion of the box's own material (E = 2e5 Pa, nu = 0.3), held by its interface
alone, with Coulomb friction (mu = 10 by default).  The box is held by symmetry on its
left, front and bottom faces and loaded by the pressure p = 100 Pa on its right and back
faces and p + q (q = 50 Pa) on its top: sigma = -p I - q e_z e_z everywhere, and since
|sigma_nt| <= q / 2 < mu |sigma_nn| the interface sticks: LAGS_C = sigma_nn = -p - q n_z^2
(n the sphere's normal) at every interface point.  Prints per line: the cell, N, the
converged reason, Newton iterations, MUMPS null pivots (ICNTL(24) on), the multiplier
space (carriers, ties, weak vertices), the max and the area-weighted L2 errors of LAGS_C
(Pa) at the facets' Gauss points, max |gap| and max slip (m) and the run time.
"""
import pathlib
import sys
import tempfile
import textwrap
import time

import numpy as np

from xfemcontact._petsc import PETSc
from xfemcontact.case import load_case
from xfemcontact.model import Model

C = np.array([0.4689, 0.5311, 0.4693])
R = 0.3125
P, Q = 100.0, 50.0


def case(cell: str, n: int, mu: float) -> str:
    return textwrap.dedent(f"""
        [mesh]
        box = {{nx = {n}, ny = {n}, nz = {n}, x = [0, 1], y = [0, 1], z = [0, 1], cell = "{cell}"}}
        [material]
        E = 2.0e5
        nu = 0.3
        model = "3D"
        [interface]
        level_set = "(x - {C[0]})**2 + (y - {C[1]})**2 + (z - {C[2]})**2 - {R * R}"
        law = "contact"
        [contact]
        frottement = "COULOMB"
        coulomb = {mu}
        [[dirichlet]]
        group = "left"
        DX = 0
        [[dirichlet]]
        group = "front"
        DY = 0
        [[dirichlet]]
        group = "bottom"
        DZ = 0
        [[traction]]
        group = ["right", "back"]
        PRES = {P}
        [[traction]]
        group = "top"
        PRES = {P + Q}
        """)


def main() -> None:
    cells = sys.argv[1].split(",") if len(sys.argv) > 1 else ["HEXA20", "TETRA10"]
    sizes = [int(s) for s in sys.argv[2].split(",")] if len(sys.argv) > 2 else [4, 8, 12]
    mu = float(sys.argv[3]) if len(sys.argv) > 3 else 10.0
    PETSc.Options().setValue("mat_mumps_icntl_24", 1)
    for cell in cells:
        for n in sizes:
            t0 = time.time()
            path = pathlib.Path(tempfile.mkdtemp()) / "case.toml"
            path.write_text(case(cell, n, mu))
            model = Model.from_case(load_case(path))
            reason = model.solve()
            v = model.interface_values()
            x = np.c_[v["x"], v["y"], v["z"]]
            nz = (x[:, 2] - C[2]) / np.linalg.norm(x - C, axis=1)
            err = np.abs(v["LAGS_C"] + P + Q * nz ** 2)
            l2 = np.sqrt((v["w"] * err ** 2).sum() / v["w"].sum())
            s = model.problem.summary()
            print(f"{cell} N={n} reason={reason} newton={sum(model.solver.record.newton)} "
                  f"null_pivots={model.solver_info()['mumps']['null_pivots']} carriers={s['carriers']} "
                  f"ties={s['ties']} weak={s['weak_vertices']} max_err={err.max():.3e} L2_err={l2:.3e} "
                  f"gap={np.abs(v['gap']).max():.1e} slip={v['slip'].max():.1e} time={time.time() - t0:.1f}s",
                  flush=True)


if __name__ == "__main__":
    main()
