"""Contact in 3-D on a curved interface: a sphere in the unit box under a uniform stress.

    .venv/bin/python bench/contact3d_sphere.py [HEXA20,TETRA10] [4,8,12,16,20] [mu] [--shift d]

The sphere of bench/xfem3d_geometry.py (R = 0.3125, centre (0.4689, 0.5311, 0.4693);
``--shift d`` adds d to every coordinate of the centre) is an inclusion of the box's own
material (E = 2e5 Pa, nu = 0.3), held by its interface alone, with Coulomb friction (mu =
10 by default).  The box is held by symmetry on its left, front and bottom faces and
loaded by the pressure p = 100 Pa on its right and back faces and p + q (q = 50 Pa) on its
top: sigma = -p I - q e_z e_z everywhere, and since |sigma_nt| <= q / 2 < mu |sigma_nn| the
interface sticks: LAGS_C = sigma_nn = -p - q n_z^2 (n the sphere's normal) at every
interface point.

Prints per line: the cell, N, the converged reason, Newton iterations, MUMPS null pivots
(ICNTL(24) on), the multiplier space (carriers, ties, weak vertices), the geometry (mesh
edges the sphere crosses twice, followed by the cut; edges lifted by the readjustment;
facet mid-nodes left off LN = 0; cells with a folded sub-tetrahedron), the L2 error of LAGS_C (Pa: sqrt(int
e^2 dA / int dA) by the facets' Gauss points) and its largest value at those points, the
L2 errors of the best approximations of the exact LAGS_C (L2 projections,
:func:`xfemcontact.post.projection.best_approximation`) in the run's multiplier space and
in the raw vertex space (every vertex of every interface cell a dof): the floors of the
discretisation, max |gap| and slip (m) and the run time.  Then a Markdown table with
the orders against the previous N.
"""
import pathlib
import sys
import tempfile
import textwrap
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from xfemcontact._petsc import PETSc  # noqa: E402  (sets PETSC_DIR, starts PETSc)
from xfemcontact.case import load_case  # noqa: E402
from xfemcontact.model import Model  # noqa: E402
from xfemcontact.post.projection import best_approximation, l2_norm  # noqa: E402

C = np.array([0.4689, 0.5311, 0.4693])
R = 0.3125
P, Q = 100.0, 50.0


def case(cell: str, n: int, mu: float, centre=C) -> str:
    return textwrap.dedent(f"""
        [mesh]
        box = {{nx = {n}, ny = {n}, nz = {n}, x = [0, 1], y = [0, 1], z = [0, 1], cell = "{cell}"}}
        [material]
        E = 2.0e5
        nu = 0.3
        model = "3D"
        [interface]
        level_set = "(x - {centre[0]})**2 + (y - {centre[1]})**2 + (z - {centre[2]})**2 - {R * R}"
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


def exact(x, centre=C):
    """LAGS_C = -p - q n_z^2 at points ``x (..., 3)`` of the sphere."""
    r = x - centre
    return -P - Q * (r[..., 2] / np.linalg.norm(r, axis=-1)) ** 2


def measure(cell: str, n: int, mu: float, centre=C) -> dict:
    t0 = time.time()
    path = pathlib.Path(tempfile.mkdtemp()) / "case.toml"
    path.write_text(case(cell, n, mu, centre))
    model = Model.from_case(load_case(path))
    reason = model.solve()
    pts = model.problem.points
    ref = exact(pts.x, centre)
    space = model.problem.space
    v = model.interface_values()
    err = np.abs(v["LAGS_C"] - exact(np.c_[v["x"], v["y"], v["z"]], centre))
    vertex = model.problem.vertex_values(model.x)[0]
    computed = np.einsum("kqv,kv->kq", model.mesh.element.shape_linear(pts.xi), vertex)
    s, geo = model.problem.summary(), model.geo
    return {"cell": cell, "N": n, "reason": reason, "newton": sum(model.solver.record.newton),
            "null_pivots": model.solver_info()["mumps"]["null_pivots"], "carriers": s["carriers"],
            "ties": s["ties"], "weak": s["weak_vertices"], "lifted": geo.readjustment.lifted_edges,
            "double": geo.readjustment.double_crossings,
            "off": geo.off_surface, "folded": geo.folded,
            "L2": l2_norm(model, computed - ref), "max": float(err.max()),
            "floor": l2_norm(model, best_approximation(model, ref) - ref),
            "raw": l2_norm(model, best_approximation(model, ref, raw=True) - ref),
            "gap": float(np.abs(v["gap"]).max()), "slip": float(v["slip"].max()), "time": time.time() - t0,
            "space": space}


def main(argv) -> None:
    shift = 0.0
    if "--shift" in argv:
        i = argv.index("--shift")
        shift = float(argv[i + 1])
        argv = argv[:i] + argv[i + 2:]
    cells = argv[1].split(",") if len(argv) > 1 else ["HEXA20", "TETRA10"]
    sizes = [int(s) for s in argv[2].split(",")] if len(argv) > 2 else [4, 8, 12]
    mu = float(argv[3]) if len(argv) > 3 else 10.0
    PETSc.Options().setValue("mat_mumps_icntl_24", 1)
    rows = []
    for cell in cells:
        for n in sizes:
            r = measure(cell, n, mu, C + shift)
            rows.append(r)
            print(f"{cell} N={n} reason={r['reason']} newton={r['newton']} null_pivots={r['null_pivots']} "
                  f"carriers={r['carriers']} ties={r['ties']} weak={r['weak']} double_crossed={r['double']} "
                  f"lifted_edges={r['lifted']} "
                  f"off_surface={r['off']} folded={r['folded']} L2_err={r['L2']:.3e} max_err={r['max']:.3e} "
                  f"L2_floor={r['floor']:.3e} L2_raw_floor={r['raw']:.3e} gap={r['gap']:.1e} "
                  f"slip={r['slip']:.1e} time={r['time']:.1f}s", flush=True)
    print("\n| cell | N | edges crossed twice | off-surface mid-nodes | ties | L2 error (Pa) | order "
          "| max error (Pa) | L2 floor, its space | order | L2 floor, raw space | order | computed / floor |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for i, r in enumerate(rows):
        prev = rows[i - 1] if i and rows[i - 1]["cell"] == r["cell"] else None

        def order(key):
            return f"{np.log(prev[key] / r[key]) / np.log(r['N'] / prev['N']):.2f}" if prev else ""
        print(f"| {r['cell']} | {r['N']} | {r['double']} | {r['off']} | {r['ties']} | {r['L2']:.3g} | {order('L2')} "
              f"| {r['max']:.3g} | {r['floor']:.3g} | {order('floor')} | {r['raw']:.3g} | {order('raw')} "
              f"| {r['L2'] / r['floor']:.2f} |")


if __name__ == "__main__":
    main(sys.argv)
