"""Every load kind on boundary edges the interface cuts, on structured and Gmsh meshes.

    python bench/cut_edge_loads.py          # 16 runs, about 25 s; prints a Markdown table

The straight interface y = 0.3 x + 4.1 crosses [0, 10]^2 and leaves it through the two
lateral edges; the interface sticks (mu = 1), plane stress E = 1e6, nu = 0.25; the
corners P1 (DX, DY) and P2 (DY) only remove the rigid-body motions, every edge carries
the loads.  Four load cases with closed forms:

* uniform / FORCE_CONTOUR: sigma_xx = -50, sigma_yy = -100, sigma_xy = 60 Pa as FX, FY
  on all edges (linear displacement, LAGS_C = -128.899 Pa, LAGS_F1 = -0.281851);
* uniform / PRES_REP: the same with sigma_xy = 0, as pressures;
* column / PRES_REP: body force FY = -rg, sigma_yy = S = rg (y - 10) - p,
  sigma_xx = k S, lateral pressure -k S (quadratic displacement, LAGS_C linear,
  LAGS_F1 = a (1 - k) / (mu (1 + a^2 k)));
* column / FORCE_CONTOUR: the same, the lateral load as FX.

Meshes: generated 20 x 20 TRIA6 and QUAD8, and Gmsh's (``cases/meshes/gmsh_*.msh``).
On the Gmsh quadrangles (not parallelograms) ORDRE_INT = 8 is used (with 4 the Q1
multipliers, not polynomials along the interface there, leave 3.5e-2 Pa), and the
column's quadratic displacement is not in the isoparametric space: the column's errors
there are those of the mesh (the same displacement errors without any interface).
"""
import json
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
MESHES = {
    "TRIA6 20x20": 'rectangle = { nx = 20, ny = 20, x = [0.0, 10.0], y = [0.0, 10.0], cell = "TRIA6" }',
    "QUAD8 20x20": 'rectangle = { nx = 20, ny = 20, x = [0.0, 10.0], y = [0.0, 10.0], cell = "QUAD8" }',
    "Gmsh TRIA6": f'file = "{ROOT / "cases" / "meshes" / "gmsh_tria6.msh"}"',
    "Gmsh QUAD8": f'file = "{ROOT / "cases" / "meshes" / "gmsh_quad8.msh"}"',
}
COMMON = """
[material]
E = 1.0e6
nu = 0.25
model = "C_PLAN"

[interface]
level_set = "y - a*x - b"

[contact]
frottement = "COULOMB"
coulomb = 1.0
coef_cont = 2.0e6
coef_frot = 1.0e4
seuil_init = -100.0
iter_frot_maxi = 20
resi_frot = 1.0e-10
ordre_int = ORDRE

[newton]
resi_glob_rela = 1.0e-12

[output]
plots = false
formats = []
"""
UNIFORM = """
[parameters]
sxx = -50.0
syy = -100.0
sxy = SXY
a = 0.3
b = 4.1
mu = 1.0
E = 1.0e6
nu = 0.25

[reference]
LAGS_C = "(a*a*sxx - 2*a*sxy + syy)/(1 + a*a) + 0*x"
LAGS_F1 = "(-a*sxx + (1 - a*a)*sxy + a*syy)/(mu*(a*a*sxx - 2*a*sxy + syy)) + 0*x"
DX = "(sxx - nu*syy)/E*x + (1 + nu)*sxy/E*y"
DY = "(syy - nu*sxx)/E*y + (1 + nu)*sxy/E*x"
"""
UNIFORM_LOADS = {
    "FORCE_CONTOUR": """
[[traction]]
group = "LIG1"
FX = "-sxy"
FY = "-syy"

[[traction]]
group = "LIG2"
FX = "sxx"
FY = "sxy"

[[traction]]
group = "LIG3"
FX = "sxy"
FY = "syy"

[[traction]]
group = "LIG4"
FX = "-sxx"
FY = "-sxy"
""",
    "PRES_REP": """
[[traction]]
group = ["LIG2", "LIG4"]
PRES = "-sxx"

[[traction]]
group = ["LIG1", "LIG3"]
PRES = "-syy"
"""}
COLUMN = """
[parameters]
rg = 20.0
H = 10.0
p = 50.0
k = 0.5
a = 0.3
b = 4.1
mu = 1.0
E = 1.0e6
nu = 0.25

[body_force]
FY = "-rg"

[[traction]]
group = "LIG3"
PRES = "p"

[[traction]]
group = "LIG1"
PRES = "rg*H + p"

[reference]
LAGS_C = "(rg*(y - H) - p)*(1 + a*a*k)/(1 + a*a)"
LAGS_F1 = "a*(1 - k)/(mu*(1 + a*a*k)) + 0*x"
DX = "(k - nu)*(rg*(y - H) - p)*x/E"
DY = "((1 - nu*k)*(rg*(y*y/2 - H*y) - p*y) - (k - nu)*rg*x*x/2)/E"
"""
COLUMN_LOADS = {
    "PRES_REP": """
[[traction]]
group = ["LIG2", "LIG4"]
PRES = "-k*(rg*(y - H) - p)"
""",
    "FORCE_CONTOUR": """
[[traction]]
group = "LIG2"
FX = "k*(rg*(y - H) - p)"

[[traction]]
group = "LIG4"
FX = "-k*(rg*(y - H) - p)"
"""}
FIELDS = ("LAGS_C", "LAGS_F1", "DX", "DY")


def case_text(state, kind, mesh):
    if state == "uniform":
        body = UNIFORM.replace("SXY", "60.0" if kind == "FORCE_CONTOUR" else "0.0") + UNIFORM_LOADS[kind]
    else:
        body = COLUMN + COLUMN_LOADS[kind]
    ref = dict(line.split(" = ", 1) for line in body.split("[reference]")[1].splitlines() if " = " in line)
    supports = (f'\n[[dirichlet]]\ngroup = "P1"\nDX = {ref["DX"]}\nDY = {ref["DY"]}\n'
                f'\n[[dirichlet]]\ngroup = "P2"\nDY = {ref["DY"]}\n')
    tests = "".join(f'\n[[test]]\nfield = "{f}"\ntype = "MAX_ERROR"\ntolerance = 1.0\ncriterion = "ABSOLU"\n'
                    for f in FIELDS)
    common = COMMON.replace("ORDRE", "8" if mesh == "Gmsh QUAD8" else "4")
    return f'title = "{state} {kind} {mesh}"\n\n[mesh]\n{MESHES[mesh]}\n' + body + common + supports + tests


def main():
    rows = ["| load | mesh | LAGS_C (Pa) | LAGS_F1 | DX (m) | DY (m) |", "|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        for state in ("uniform", "column"):
            for kind in ("FORCE_CONTOUR", "PRES_REP"):
                for mesh in MESHES:
                    case = tmp / "case.toml"
                    case.write_text(case_text(state, kind, mesh))
                    out = tmp / "out"
                    p = subprocess.run([sys.executable, "-m", "xfemcontact", "run", str(case), "-o", str(out),
                                        "--overwrite"], capture_output=True, text=True, cwd=ROOT)
                    if p.returncode not in (0, 1):
                        rows.append(f"| {state} {kind} | {mesh} | failed: {p.stderr.strip()[-200:]} |")
                        continue
                    tests = {t["field"]: t["value"] for t in json.loads((out / "results.json").read_text())["tests"]}
                    rows.append(f"| {state} {kind} | {mesh} | " + " | ".join(f"{tests[f]:.1e}" for f in FIELDS) + " |")
                    print(rows[-1], flush=True)
    print("\n".join(rows))


if __name__ == "__main__":
    main()
