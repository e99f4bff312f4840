"""Thin spherical caps just above a plane of vertices: a uniform pressure, frictionless.

    .venv/bin/python bench/contact3d_caps.py [HEXA20,TETRA10] [3,4,5,6] [1,2,5,20] [0.34,0.40] [-v]

The unit box (N x N x N HEXA20 or TETRA10, E = 2e5 Pa, nu = 0.3) is cut by the sphere of
radius R centred at (0.5, 0.5, top - R): a cap whose top is at z = top.  With top = 0.34
the top is 0.0067 m above the vertex plane z = 1/3 of N = 3 and 6 (0.02 h and 0.04 h),
and the cap crosses the plane (the circle where it does has the radius sqrt(2 R 0.0067),
0.12 m for R = 1, 0.52 m for R = 20); N = 4 and 5 have no vertex plane near the top
(0.34 - 0.25 = 0.36 h; 0.4 - 0.34 = 0.3 h).  top = 0.40 is the comparison at a position that
is not near a vertex plane for N = 3, 4 and 6 (0.2 h, 0.4 h, 0.4 h; N = 5: on the plane
z = 0.4, a cap touching it).  The box is held by symmetry on its left, front and bottom
faces and loaded by p = 100 Pa on its right, back and top faces: sigma = -p I in both
bodies, LAGS_C = -p at every interface point, zero gap and slip.

Prints per case: the converged reason, MUMPS null pivots (ICNTL(24) on), the multiplier
space (carriers, merges, weak vertices, its smallest scaled trace eigenvalue), max |LAGS_C +
p| / p at the facets' Gauss points (what interface.csv holds) and its L2 mean (by the
points' area weights), the interface area (m^2), the range of the vertex
values of LAGS_C (Pa; extrapolated vertices included), the number of multiplier dofs not in
contact, max |gap| (m).  With ``-v`` the worst vertices: id, position, their largest and
lumped weights, carrier or not, value.
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

P = 100.0


def case(cell: str, n: int, radius: float, top: float) -> str:
    return textwrap.dedent(f"""
        [mesh]
        box = {{nx = {n}, ny = {n}, nz = {n}, x = [0, 1], y = [0, 1], z = [0, 1], cell = "{cell}"}}
        [material]
        E = 2.0e5
        nu = 0.3
        model = "3D"
        [interface]
        level_set = "sqrt((x - 0.5)**2 + (y - 0.5)**2 + (z - ({top} - {radius}))**2) - {radius}"
        law = "contact"
        [contact]
        frottement = "SANS"
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
        group = ["right", "back", "top"]
        PRES = {P}
        """)


def measure(cell: str, n: int, radius: float, top: float, verbose: bool = False) -> dict:
    t0 = time.time()
    path = pathlib.Path(tempfile.mkdtemp()) / "case.toml"
    path.write_text(case(cell, n, radius, top))
    model = Model.from_case(load_case(path))
    reason = model.solve()
    v = model.interface_values()
    e = np.abs(v["LAGS_C"] + P) / P
    err, l2 = e.max(), np.sqrt((v["w"] * e**2).sum() / v["w"].sum())
    vv = model.problem.vertex_values(model.x)
    lam = vv[0]
    s = model.problem.summary()
    info = model.solver_info()
    out = {"cell": cell, "N": n, "R": radius, "top": top, "reason": reason,
           "null_pivots": info["mumps"]["null_pivots"], "carriers": s["carriers"],
           "ties": s["ties"], "weak": s["weak_vertices"], "smallest": s["smallest_trace_eigenvalue"],
           "err": float(err), "l2": float(l2), "area": float(v["w"].sum()), "lam_min": float(lam.min()), "lam_max": float(lam.max()),
           "open": _open_dofs(model), "gap": float(np.abs(v["gap"]).max()),
           "time": time.time() - t0}
    if verbose:
        _worst(model, lam)
    return out


def _open_dofs(model) -> int:
    """Multiplier dofs (carriers) not in contact."""
    co = model.problem.space.carriers_of
    return len(np.unique(co[(co >= 0) & (model.problem.chi == 0)]))


def _worst(model, lam) -> None:
    """The vertices whose LAGS_C is farthest from -p, with their weights."""
    pr = model.problem
    space = pr.space
    pts = pr.points
    lin = model.mesh.element.shape_linear(pts.xi)                      # (k, q, nv)
    w = pts.w if hasattr(pts, "w") else pts.weights
    topo = space.topo
    verts = topo.verts
    ids = np.unique(verts)
    maxw = np.zeros(len(ids))
    lump = np.zeros(len(ids))
    live = (w != 0)[..., None]
    np.maximum.at(maxw, np.searchsorted(ids, verts.ravel()),
                  np.max(np.where(live, lin, 0), axis=1).ravel())
    np.add.at(lump, np.searchsorted(ids, verts.ravel()), np.einsum("kq,kqv->kv", w, lin).ravel())
    val = np.zeros(len(ids))
    val[np.searchsorted(ids, verts.ravel())] = lam.ravel()
    xv = np.zeros((len(ids), 3))
    xv[np.searchsorted(ids, verts.ravel())] = topo.xv.reshape(-1, 3)
    carrier = np.isin(ids, space.rep)
    order = np.argsort(-np.abs(val + P))[:8]
    for i in order:
        print(f"    vertex {ids[i]} at {np.round(xv[i], 4)} max weight {maxw[i]:.3g} lumped {lump[i]:.3g} "
              f"carrier {carrier[i]} LAGS_C {val[i]:.4g}")


def main(argv) -> None:
    verbose = "-v" in argv
    argv = [a for a in argv if a != "-v"]
    cells = argv[1].split(",") if len(argv) > 1 else ["HEXA20", "TETRA10"]
    sizes = [int(s) for s in argv[2].split(",")] if len(argv) > 2 else [3, 4, 5, 6]
    radii = [float(s) for s in argv[3].split(",")] if len(argv) > 3 else [1.0, 2.0, 5.0, 20.0]
    tops = [float(s) for s in argv[4].split(",")] if len(argv) > 4 else [0.34, 0.40]
    PETSc.Options().setValue("mat_mumps_icntl_24", 1)
    rows = []
    for cell in cells:
        for n in sizes:
            for radius in radii:
                for top in tops:
                    r = measure(cell, n, radius, top, verbose)
                    rows.append(r)
                    print(f"{cell} N={n} R={radius:g} top={top:g} reason={r['reason']} "
                          f"null_pivots={r['null_pivots']} carriers={r['carriers']} ties={r['ties']} "
                          f"weak={r['weak']} smallest={r['smallest']:.2e} err={r['err']:.2e} L2={r['l2']:.2e} "
                          f"area={r['area']:.5f} "
                          f"dofs=[{r['lam_min']:.4g}, {r['lam_max']:.4g}] open={r['open']} "
                          f"gap={r['gap']:.1e} time={r['time']:.1f}s", flush=True)
    print("\n| cell | N | R (m) | " + " | ".join(
        f"top {t:g}: max err / p | L2 / p | vertex LAGS_C (Pa) | null pivots" for t in tops) + " |")
    print("|---|---|---|" + "---|---|---|---|" * len(tops))
    for i in range(0, len(rows), len(tops)):
        grp = rows[i:i + len(tops)]
        r0 = grp[0]
        cols = " | ".join(f"{r['err']:.1e}{' (' + str(r['open']) + ' open)' if r['open'] else ''} | {r['l2']:.1e} | "
                          f"{r['lam_min']:.4g} .. {r['lam_max']:.4g} | {r['null_pivots']}" for r in grp)
        print(f"| {r0['cell']} | {r0['N']} | {r0['R']:g} | {cols} |")


if __name__ == "__main__":
    main(sys.argv)
