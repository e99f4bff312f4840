"""code_aster's Gauss-point contact (``integration = "GAUSS"``) in 3-D against the conditions
at the dofs (``"NOEUD"``): errors, Newton iterations, and the coefficients' influence.

    .venv/bin/python bench/gauss3d.py [--quick | --exact | --sweeps]

1. *Exact states* (the boxes of tests/test_contact3d.py, 3 x 3 x 3, E = 2e5 / 1e6 Pa): a
   uniform pressure p = 100 Pa across the planes z = 0.45 and z = 0.45 + 0.1 x - 0.05 y
   (frictionless), the top lifted by 1e-4 m (opening), a uniform stress with |tau| = 40 Pa
   < mu p = 50 Pa (stick, both friction forms of GAUSS) and tau = mu p with the top moved by
   5e-4 m (slip), on HEXA20 and TETRA10: the largest errors at the facets' Gauss points
   (LAGS_C and T relative to p, LAGS_F1 / LAGS_F2 absolute, the gap in m) and the Newton
   iterations of the whole run, GAUSS and NOEUD.
2. *Coefficient sweep in slip*: COEF_CONT = a E/h and COEF_FROT = b E/(h mu p) for a, b in
   1e-2, 1, 1e2, (i) on the uniform slip (TETRA10, tilted plane: the exact state is in the
   discrete space) and (ii) on a partial slip without closed form: the sphere of
   bench/contact3d_sphere.py (R = 0.3125, TETRA10 6 x 6 x 6, sigma = -p I - q e_z e_z, mu =
   0.15: the interface slips where q n_z sqrt(1 - n_z^2) > mu (p + q n_z^2)).  Per run the
   Newton iterations and, at the facets' Gauss points, max LAGS_C, max |(LAGS_F1, LAGS_F2)|
   (1 at most by Coulomb); over the runs the spread (largest max - min at a point) of LAGS_C
   and T.  NOEUD on the same cases with the same coefficients (its answer does not depend
   on them).

``--exact``: part 1 only, ``--sweeps``: part 2 only, ``--quick``: without the sphere.
Writes bench/results/gauss3d.md and gauss3d.json (gauss3d_exact.*, gauss3d_sweeps.*).
"""
import json
import pathlib
import sys
import tempfile
import textwrap
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from xfemcontact.case import load_case  # noqa: E402
from xfemcontact.model import Model  # noqa: E402
from xfemcontact.xfem import integration3d  # noqa: E402

from test_contact3d import MU, P, SYMMETRY, box, sheared  # noqa: E402

PLANES = {"z = 0.45": ("z - 0.45", (0, 0, 1)), "tilted": ("z - 0.45 - 0.1*x + 0.05*y", (-0.1, 0.05, 1))}
FACTORS = (1e-2, 1.0, 1e2)


def with_keys(text: str, **keys) -> str:
    """``text`` with ``[contact]`` keys added (values as TOML text)."""
    lines = "".join(f"{k} = {v}\n" for k, v in keys.items())
    text = textwrap.dedent(text)
    return text.replace("[contact]\n", "[contact]\n" + lines, 1)


def run(text: str) -> tuple[Model, dict, float]:
    """Solve the case ``text``; returns the model, its interface values and the seconds."""
    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(tmp) / "case.toml"
        path.write_text(textwrap.dedent(text))
        t0 = time.perf_counter()
        model = Model.from_case(load_case(path))
        reason = model.solve()
        seconds = time.perf_counter() - t0
    if reason <= 0:
        return model, {}, seconds
    return model, model.interface_values(), seconds


def newton(model: Model) -> int:
    return int(model.solver.iterations()["newton"])


def errors(v: dict, n=None, d=None, tau=0.0, lift=None) -> dict:
    """Largest errors against the uniform states (see the module documentation)."""
    out = {"LAGS_C": float(np.abs(v["LAGS_C"] + (0.0 if lift else P)).max() / (1.0 if lift else P)),
           "gap": float(np.abs(v["gap"] - (lift or 0.0)).max())}
    if n is not None:
        B = integration3d.tangent_basis(n, integration3d.interface_axis(n[None, None], np.ones((1, 1))))
        expected = (tau * d) @ B / (MU * -P)
        out["T"] = float(np.abs(v["T"] - tau).max() / P)
        out["LAGS_F"] = float(max(np.abs(v["LAGS_F1"] - expected[0]).max(), np.abs(v["LAGS_F2"] - expected[1]).max()))
    return out


def exact_states() -> list[dict]:
    rows = []
    for cell in ("HEXA20", "TETRA10"):
        for name, (ls, grad) in PLANES.items():
            loads = SYMMETRY + f"""
                [[traction]]
                group = ["right", "back", "top"]
                PRES = {P}
                """
            text = box(cell, ls, textwrap.dedent(loads), 'frottement = "SANS"')
            rows.append(compare(f"frictionless, {name}", cell, text, lambda v: errors(v)))
        lift = 1e-4
        loads = SYMMETRY + f"""
            [[dirichlet]]
            group = "top"
            DZ = {lift}
            """
        text = box(cell, PLANES["tilted"][0], textwrap.dedent(loads), 'frottement = "SANS"')
        rows.append(compare("opening, tilted", cell, text, lambda v: errors(v, lift=lift / np.sqrt(1.0125))))
        for kind, tau, slip in (("stick", 40.0, 0.0), ("slip", MU * P, 5e-4)):
            for name, (ls, grad) in PLANES.items():
                text, n, d = sheared(cell, ls, grad, tau, slip)
                check = (lambda n, d, tau: lambda v: errors(v, n, d, tau))(n, d, tau)
                rows.append(compare(f"{kind}, {name}", cell, text, check))
                rows.append(compare(f"{kind}, {name}, SEUIL_INIT = -p", cell, text, check,
                                    gauss_keys={"seuil_init": repr(-P)}))
                if kind == "stick" and name == "tilted":
                    rows.append(compare(f"{kind}, {name}, TRACTION", cell, text, check,
                                        gauss_keys={"friction_unknown": '"TRACTION"'}))
    return rows


def compare(label: str, cell: str, text: str, check, gauss_keys=None) -> dict:
    """GAUSS and NOEUD on one case: errors, Newton iterations, seconds."""
    row = {"case": label, "cell": cell}
    for form, keys in (("GAUSS", dict({"integration": '"GAUSS"'}, **(gauss_keys or {}))), ("NOEUD", {})):
        model, v, seconds = run(with_keys(text, **keys))
        row[form] = {"newton": newton(model), "seconds": round(seconds, 2),
                     "errors": check(v) if v else None}
    print(json.dumps(row), flush=True)
    return row


def sphere_case(n: int, mu: float) -> str:
    from contact3d_sphere import case

    return case("TETRA10", n, mu)


def sweep(label: str, text: str, mu: float, pressure: float) -> dict:
    """GAUSS (and NOEUD) over COEF_CONT = a E/h, COEF_FROT = b E/(h mu p), a, b in FACTORS."""
    model, _, _ = run(with_keys(text, integration='"GAUSS"'))
    E, h = model.case.material.E, model.problem.law.coef_cont
    kappa = h                                        # E / h: the natural COEF_CONT
    runs = {}
    for form in ("GAUSS", "NOEUD"):
        values = []
        for a in FACTORS:
            for b in FACTORS:
                keys = {"coef_cont": repr(a * kappa), "coef_frot": repr(b * kappa / (mu * pressure))}
                if form == "GAUSS":
                    keys["integration"] = '"GAUSS"'
                model, v, seconds = run(with_keys(text, **keys))
                entry = {"a": a, "b": b, "newton": newton(model), "converged": bool(v), "seconds": round(seconds, 2)}
                if v:
                    entry.update({"max_LAGS_C": float(v["LAGS_C"].max()),
                                  "max_F": float(np.hypot(v["LAGS_F1"], v["LAGS_F2"]).max()),
                                  "sliding": float(np.mean(v["sliding"]))})
                    values.append(v)
                print(form, json.dumps(entry), flush=True)
                runs.setdefault(form, []).append(entry)
        if values:
            for key in ("LAGS_C", "T"):
                stack = np.array([v[key] for v in values])
                runs.setdefault(form + "_spread", {})[key] = float((stack.max(axis=0) - stack.min(axis=0)).max())
    print(label, json.dumps({k: v for k, v in runs.items() if k.endswith("spread")}), flush=True)
    return {"case": label, "E_over_h": kappa, "E": E, "runs": runs}


def markdown(rows: list[dict], sweeps: list[dict]) -> str:
    out = ["# Gauss-point contact in 3-D (bench/gauss3d.py)", "",
           "| case | cell | GAUSS: LAGS_C / T / LAGS_F / gap errors | Newton GAUSS | Newton NOEUD |", "|---|---|---|---|---|"]
    for r in rows:
        e = r["GAUSS"]["errors"] or {}
        err = " / ".join(f"{e[k]:.1e}" if k in e else "-" for k in ("LAGS_C", "T", "LAGS_F", "gap"))
        out.append(f"| {r['case']} | {r['cell']} | {err} | {r['GAUSS']['newton']} | {r['NOEUD']['newton']} |")
    for s in sweeps:
        out += ["", f"## {s['case']}", "",
                "| form | a | b | converged | Newton | max LAGS_C | max \\|F\\| | sliding points |",
                "|---|---|---|---|---|---|---|---|"]
        for form in ("GAUSS", "NOEUD"):
            for e in s["runs"].get(form, []):
                out.append(f"| {form} | {e['a']:g} | {e['b']:g} | {e['converged']} | {e['newton']} | "
                           f"{e.get('max_LAGS_C', float('nan')):.4g} | {e.get('max_F', float('nan')):.6g} | "
                           f"{100 * e.get('sliding', float('nan')):.0f} % |")
            sp = s["runs"].get(form + "_spread", {})
            out.append(f"| {form} spread | | | | | LAGS_C {sp.get('LAGS_C', float('nan')):.2e} Pa | "
                       f"T {sp.get('T', float('nan')):.2e} Pa | |")
    return "\n".join(out) + "\n"


def main() -> None:
    quick = "--quick" in sys.argv
    sys.path.insert(0, str(ROOT / "bench"))
    rows = [] if "--sweeps" in sys.argv else exact_states()
    sweeps = []
    if "--exact" not in sys.argv:
        text, n, d = sheared("TETRA10", *PLANES["tilted"], MU * P, 5e-4)
        sweeps.append(sweep("uniform slip, TETRA10, tilted plane", text, MU, P))
        if not quick:
            sweeps.append(sweep("sphere, partial slip (mu = 0.15), TETRA10 6 x 6 x 6", sphere_case(6, 0.15), 0.15,
                                100.0))
    res = ROOT / "bench" / "results"
    name = "gauss3d" + ("_exact" if "--exact" in sys.argv else "_sweeps" if "--sweeps" in sys.argv else "")
    (res / f"{name}.json").write_text(json.dumps({"exact": rows, "sweeps": sweeps}, indent=1))
    (res / f"{name}.md").write_text(markdown(rows, sweeps))
    print(markdown(rows, sweeps))


if __name__ == "__main__":
    main()
