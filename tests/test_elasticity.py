"""Plain (interface-free) elasticity: patch tests, exact quadratic fields, SSNV509's
plate without interface, and one process against two.

Every check here is exact in exact arithmetic, so the tolerances are round-off
ones (1e-10 relative): a linear field is reproduced by QUAD8 and TRIA6 on any
straight-sided mesh, a quadratic one by TRIA6 on straight-sided triangles and by
QUAD8 on parallelograms (serendipity contains P2, the map is affine), with the
constant body force and the linear tractions integrated exactly.
"""
import numpy as np
import pytest

from conftest import MESHES, ROOT, results, run_cli, run_python, write_case
from xfemcontact.case import load_case
from xfemcontact.fem.elasticity import hooke
from xfemcontact.mesh.generate import rectangle
from xfemcontact.model import Model

SCRIPTS = ROOT / "tests" / "scripts"
RTOL = 1e-10
E, NU = 2.0e5, 0.3
SIDES = ("LIG1", "LIG2", "LIG3", "LIG4")


# --- meshes ---------------------------------------------------------------------------------

def straighten(raw):
    """Put every mid-edge node at the midpoint of its edge (edge k: vertex k to k+1)."""
    nv = raw.n_vertices_per_cell
    for k in range(nv):
        a, b = raw.cells[:, k], raw.cells[:, (k + 1) % nv]
        raw.points[raw.cells[:, nv + k]] = 0.5 * (raw.points[a] + raw.points[b])
    return raw


def distorted(nx, ny, cell, seed=12345, fraction=0.2, x=(0.0, 10.0), y=(0.0, 10.0)):
    """``rectangle(...)`` with its interior vertices moved by up to ``fraction * h`` in a
    random direction (fixed seed), mid-edge nodes at the midpoints: straight-sided cells."""
    raw = rectangle(nx, ny, x=x, y=y, cell=cell)
    raw.points = raw.points.astype(float).copy()
    h = min((x[1] - x[0]) / nx, (y[1] - y[0]) / ny)
    p = raw.points
    v = raw.vertex_nodes
    tol = 1e-9 * h
    interior = v[(p[v, 0] > x[0] + tol) & (p[v, 0] < x[1] - tol)
                 & (p[v, 1] > y[0] + tol) & (p[v, 1] < y[1] - tol)]
    rng = np.random.default_rng(seed)
    r = fraction * h * rng.uniform(0.0, 1.0, len(interior))
    t = rng.uniform(0.0, 2.0 * np.pi, len(interior))
    p[interior] += np.c_[r * np.cos(t), r * np.sin(t)]
    straighten(raw)
    raw.source = f"<distorted {nx}x{ny} {cell}>"
    return raw.check()


def sheared(nx, ny, cell, s=0.3):
    """``rectangle(...)`` mapped by x' = x + s y: parallelogram cells."""
    raw = rectangle(nx, ny, cell=cell)
    raw.points = raw.points.astype(float).copy()
    raw.points[:, 0] += s * raw.points[:, 1]
    raw.source = f"<sheared {nx}x{ny} {cell}>"
    return raw.check()


def test_distorted_meshes_are_really_distorted():
    """The helper gives general (non-parallelogram) quadrilaterals with straight sides."""
    raw = distorted(4, 4, "QUAD8")
    v = raw.points[raw.cells[:, :4]]
    defect = np.abs(v[:, 0] + v[:, 2] - v[:, 1] - v[:, 3]).max(axis=1)
    assert (defect > 0.05).sum() >= 8                          # h = 2.5
    mids = raw.points[raw.cells[:, 4:]]
    assert np.allclose(mids, 0.5 * (v + np.roll(v, -1, axis=1)), rtol=0, atol=1e-14)
    ref = rectangle(4, 4, cell="QUAD8")
    assert np.abs(raw.points - ref.points).max() <= 0.2 * 2.5 + 1e-12
    assert np.abs(raw.points - ref.points).max() > 0.1


# --- cases ----------------------------------------------------------------------------------

def fmt(c0, cx, cy, c2=()):
    """Formula text ``c0 + cx*x + cy*y [+ cxx*x**2 + cxy*x*y + cyy*y**2]`` (exact reprs)."""
    terms = [f"({c0!r})", f"({cx!r})*x", f"({cy!r})*y"]
    if c2:
        terms += [f"({c2[0]!r})*x**2", f"({c2[1]!r})*x*y", f"({c2[2]!r})*y**2"]
    return " + ".join(terms)


def case_text(cell, model="D_PLAN", nx=4, ny=4, dirichlet=(), traction=(), body=None):
    """A plain elasticity case; ``dirichlet``/``traction``: (groups, FX/DX formula, FY/DY formula)."""
    lines = ["[mesh]", f'rectangle = {{ nx = {nx}, ny = {ny}, cell = "{cell}" }}', "",
             "[material]", f"E = {E!r}", f"nu = {NU!r}", f'model = "{model}"', "",
             "[newton]", "resi_glob_rela = 1e-12", ""]
    for groups, dx, dy in dirichlet:
        lines += ["[[dirichlet]]", f"group = {list(groups)!r}".replace("'", '"'),
                  f'DX = "{dx}"', f'DY = "{dy}"', ""]
    for groups, fx, fy in traction:
        lines += ["[[traction]]", f"group = {list(groups)!r}".replace("'", '"'),
                  f'FX = "{fx}"', f'FY = "{fy}"', ""]
    if body is not None:
        lines += ["[body_force]", f"FX = {body[0]!r}", f"FY = {body[1]!r}", ""]
    return "\n".join(lines)


def solve(tmp_path, text, raw):
    case = load_case(write_case(tmp_path, text))
    model = Model(case, raw=raw)
    reason = model.solve()
    assert reason > 0, f"no convergence (reason {reason})"
    return model


def rel_node_error(model, exact):
    u = model.displacement()
    ue = exact(model.mesh.x)
    assert u.shape == ue.shape
    return np.abs(u - ue).max() / np.abs(ue).max()


def live_stresses(model):
    """Points ``(m, 2)`` and stresses ``(m, 3)`` at every (non-padding) quadrature point."""
    xs, ss = [], []
    for v in model.stresses():
        live = v.w > 0
        xs.append(v.x[live])
        ss.append(v.stress[live])
    x, s = np.concatenate(xs), np.concatenate(ss)
    assert len(s) > 0
    return x, s


# --- 1. patch test --------------------------------------------------------------------------

A = (1.0e-3, 2.0e-4, -1.0e-4)            # u_x = a0 + a1 x + a2 y
B = (-5.0e-4, 3.0e-4, 1.5e-4)            # u_y = b0 + b1 x + b2 y


def linear_u(x):
    return np.c_[A[0] + A[1] * x[:, 0] + A[2] * x[:, 1], B[0] + B[1] * x[:, 0] + B[2] * x[:, 1]]


MESHES_LINEAR = {
    "structured": lambda cell: rectangle(4, 4, cell=cell),
    "distorted": lambda cell: distorted(5, 4, cell, seed=7),
}


@pytest.mark.parametrize("model", ["C_PLAN", "D_PLAN"])
@pytest.mark.parametrize("mesh", sorted(MESHES_LINEAR))
@pytest.mark.parametrize("cell", ["QUAD8", "TRIA6"])
def test_patch_linear_field(tmp_path, cell, mesh, model):
    text = case_text(cell, model, dirichlet=[(SIDES, fmt(*A), fmt(*B))])
    m = solve(tmp_path, text, MESHES_LINEAR[mesh](cell))
    assert rel_node_error(m, linear_u) <= RTOL
    eps = np.array([A[1], B[2], A[2] + B[1]])
    sigma = hooke(E, NU, model) @ eps
    _, s = live_stresses(m)
    assert np.abs(s - sigma).max() <= RTOL * np.abs(sigma).max()


# --- 2. quadratic field with body force (and tractions) --------------------------------------

P = (1.0e-3, 2.0e-4, -1.0e-4, 3.0e-5, -2.0e-5, 1.0e-5)   # u_x = p0 + p1 x + p2 y + p3 x^2 + p4 xy + p5 y^2
Q = (-5.0e-4, 1.0e-4, 2.0e-4, -1.0e-5, 2.5e-5, -3.0e-5)  # u_y likewise


def quadratic_u(x):
    X, Y = x[:, 0], x[:, 1]
    return np.c_[P[0] + P[1] * X + P[2] * Y + P[3] * X**2 + P[4] * X * Y + P[5] * Y**2,
                 Q[0] + Q[1] * X + Q[2] * Y + Q[3] * X**2 + Q[4] * X * Y + Q[5] * Y**2]


def quadratic_stress(model="D_PLAN"):
    """sigma = s0 + sx x + sy y (Voigt, each (3,)) and the constant body force -div sigma."""
    D = hooke(E, NU, model)
    # strains (exx, eyy, gxy) = e0 + ex x + ey y
    e0 = np.array([P[1], Q[2], P[2] + Q[1]])
    ex = np.array([2 * P[3], Q[4], P[4] + 2 * Q[3]])
    ey = np.array([P[4], 2 * Q[5], 2 * P[5] + Q[4]])
    s0, sx, sy = D @ e0, D @ ex, D @ ey
    body = (-(sx[0] + sy[2]), -(sx[2] + sy[1]))
    return s0, sx, sy, body


def traction_formulas(n, model="D_PLAN"):
    """FX, FY formulas of sigma.n for a constant unit normal n."""
    s0, sx, sy, _ = quadratic_stress(model)
    # t_x = sxx nx + sxy ny, t_y = sxy nx + syy ny
    tx = [n[0] * s[0] + n[1] * s[2] for s in (s0, sx, sy)]
    ty = [n[0] * s[2] + n[1] * s[1] for s in (s0, sx, sy)]
    return fmt(*tx), fmt(*ty)


QUAD_DX, QUAD_DY = fmt(*P[:3], P[3:]), fmt(*Q[:3], Q[3:])

MESHES_QUADRATIC = {
    "TRIA6-structured": lambda: rectangle(4, 4, cell="TRIA6"),
    "TRIA6-distorted": lambda: distorted(4, 5, "TRIA6", seed=11),
    "QUAD8-parallelogram": lambda: sheared(4, 4, "QUAD8"),
}


def test_quadratic_stress_is_consistent():
    """The hand-derived sigma and body force agree with finite differences of the field."""
    s0, sx, sy, body = quadratic_stress()
    D = hooke(E, NU, "D_PLAN")
    h = 1e-3
    pt = np.array([[1.3, 2.7]])

    def sigma(x):
        g = np.array([[(quadratic_u(x + h * d)[0, i] - quadratic_u(x - h * d)[0, i]) / (2 * h)
                       for d in (np.array([[1.0, 0.0]]), np.array([[0.0, 1.0]]))] for i in (0, 1)])
        return D @ np.array([g[0, 0], g[1, 1], g[0, 1] + g[1, 0]])

    assert np.allclose(sigma(pt), s0 + sx * 1.3 + sy * 2.7, rtol=1e-8, atol=0)
    div = [((sigma(pt + [[h, 0]]) - sigma(pt - [[h, 0]])) / (2 * h)),
           ((sigma(pt + [[0, h]]) - sigma(pt - [[0, h]])) / (2 * h))]
    assert np.allclose([-(div[0][0] + div[1][2]), -(div[0][2] + div[1][1])], body,
                       rtol=1e-6, atol=0)


@pytest.mark.parametrize("mesh", sorted(MESHES_QUADRATIC))
def test_quadratic_field_body_force(tmp_path, mesh):
    *_, body = quadratic_stress()
    text = case_text("TRIA6" if mesh.startswith("TRIA6") else "QUAD8",
                     dirichlet=[(SIDES, QUAD_DX, QUAD_DY)], body=body)
    m = solve(tmp_path, text, MESHES_QUADRATIC[mesh]())
    assert rel_node_error(m, quadratic_u) <= RTOL
    # and the stress is the exact linear one at every quadrature point
    s0, sx, sy, _ = quadratic_stress()
    x, s = live_stresses(m)
    exact = s0 + x[:, :1] * sx + x[:, 1:] * sy
    assert np.abs(s - exact).max() <= RTOL * np.abs(exact).max()


def test_quadratic_field_needs_the_body_force(tmp_path):
    """Control: without the body force the same boundary values do not give the field."""
    text = case_text("TRIA6", dirichlet=[(SIDES, QUAD_DX, QUAD_DY)])
    m = solve(tmp_path, text, rectangle(4, 4, cell="TRIA6"))
    assert rel_node_error(m, quadratic_u) > 1e-4


TRACTION_MESHES = {
    "TRIA6-structured": (lambda: rectangle(4, 4, cell="TRIA6"), 0.0),
    "TRIA6-distorted": (lambda: distorted(4, 5, "TRIA6", seed=5), 0.0),
    "QUAD8-structured": (lambda: rectangle(4, 4, cell="QUAD8"), 0.0),
    "QUAD8-parallelogram": (lambda: sheared(4, 4, "QUAD8"), 0.3),
}


@pytest.mark.parametrize("mesh", sorted(TRACTION_MESHES))
def test_quadratic_field_tractions(tmp_path, mesh):
    """u imposed on the bottom and left sides, sigma.n on the top and right ones."""
    build, shear = TRACTION_MESHES[mesh]
    *_, body = quadratic_stress()
    right = np.array([1.0, -shear]) / np.hypot(1.0, shear)    # x - shear*y = const
    text = case_text("TRIA6" if mesh.startswith("TRIA6") else "QUAD8",
                     dirichlet=[(("LIG1", "LIG4"), QUAD_DX, QUAD_DY)],
                     traction=[(("LIG3",), *traction_formulas((0.0, 1.0))),
                               (("LIG2",), *traction_formulas(right))],
                     body=body)
    m = solve(tmp_path, text, build())
    assert rel_node_error(m, quadratic_u) <= RTOL


# --- 3. SSNV509's plate without interface ---------------------------------------------------

SSNV509_PLAIN = """\
    [mesh]
    {mesh}

    [material]
    E = 1.0e6
    nu = 0.0

    [[dirichlet]]
    group = "LIG1"
    DX = 0.0
    DY = 0.0

    [[dirichlet]]
    group = "LIG3"
    DX = 0.0
    DY = -1.0e-6

    [newton]
    resi_glob_rela = 1e-12
"""


@pytest.mark.parametrize("mesh", [
    'rectangle = { nx = 20, ny = 20, cell = "QUAD8" }',
    f'file = "{MESHES / "ssnv509a.mmed"}"',
    f'file = "{MESHES / "ssnv509b.mmed"}"',
], ids=["generated-20x20-QUAD8", "ssnv509a.mmed", "ssnv509b.mmed"])
def test_ssnv509_plate_without_interface(tmp_path, mesh):
    case = load_case(write_case(tmp_path, SSNV509_PLAIN.format(mesh=mesh)))
    m = Model(case)
    assert m.solve() > 0
    u, x = m.displacement(), m.mesh.x
    exact = np.c_[np.zeros(len(x)), -1e-7 * x[:, 1]]
    assert np.abs(u - exact).max() <= RTOL * 1e-6
    _, s = live_stresses(m)
    assert np.abs(s[:, 1] + 0.1).max() <= RTOL * 0.1
    assert np.abs(s[:, 0]).max() <= 1e-12
    assert np.abs(s[:, 2]).max() <= 1e-12


# --- 4. one process against two -------------------------------------------------------------

def test_script_quadratic_case_is_exact(tmp_path):
    """The case of the MPI comparison is itself solved exactly (serial, in process)."""
    *_, body = quadratic_stress()
    text = case_text("TRIA6", nx=12, ny=12, dirichlet=[(SIDES, QUAD_DX, QUAD_DY)], body=body)
    case = load_case(write_case(tmp_path, text))
    m = Model(case)
    assert m.solve() > 0
    assert rel_node_error(m, quadratic_u) <= RTOL


def _mpi_case(tmp_path):
    *_, body = quadratic_stress()
    # the body force alone (no exactness) with tractions, so that the field is non-trivial
    # and every kind of load crosses the partition
    text = case_text("TRIA6", nx=12, ny=12,
                     dirichlet=[(("LIG1",), QUAD_DX, QUAD_DY)],
                     traction=[(("LIG3",), *traction_formulas((0.0, 1.0))),
                               (("LIG2",), "1.0e1*y", "-2.0e1")],
                     body=(body[0], 3.0 * body[1]))
    return write_case(tmp_path, text)


@pytest.mark.mpi
def test_mpi_two_processes_same_field(tmp_path):
    case = _mpi_case(tmp_path)
    fields = {}
    for np_ in (None, 2):
        out = tmp_path / f"u_{np_ or 1}.npz"
        proc = run_python(SCRIPTS / "solve_gather.py", np=np_, timeout=120, args=(case, out))
        assert proc.returncode == 0, proc.stderr[-3000:]
        data = np.load(out)
        assert int(data["size"]) == (np_ or 1)
        fields[np_ or 1] = data
    one, two = fields[1], fields[2]
    assert len(one["ids"]) == (2 * 12 + 1) ** 2
    assert np.array_equal(one["ids"], np.arange(len(one["ids"])))
    assert np.array_equal(np.sort(one["ids"]), np.sort(two["ids"]))
    o1, o2 = np.argsort(one["ids"]), np.argsort(two["ids"])
    assert np.array_equal(one["x"][o1], two["x"][o2])
    u1, u2 = one["u"][o1], two["u"][o2]
    scale = np.abs(u1).max()
    assert scale > 1e-4
    assert np.abs(u1 - u2).max() <= 1e-10 * scale
    # both processes did own nodes
    assert len(set(two["rank"].tolist())) == 2


@pytest.mark.mpi
def test_mpi_cli_same_tests_and_files(tmp_path):
    case = _mpi_case(tmp_path)
    text = case.read_text() + "\n".join([
        "", "[[test]]", 'field = "DX"', 'type = "MAX"', "reference = 1.0", "tolerance = 1e3", "",
        "[[test]]", 'field = "DY"', 'type = "MIN"', "reference = -1.0", "tolerance = 1e3", "",
        "[[test]]", 'field = "DY"', 'type = "VALUE"', "point = [5.0, 5.0]", "reference = 1.0",
        "tolerance = 1e3", "",
        "[[test]]", 'field = "SIYY"', 'type = "SOMM_ABS"', "reference = 1.0", "tolerance = 1e9", "",
        "[[test]]", 'field = "SIXY"', 'type = "MAX"', "reference = 1.0", "tolerance = 1e9", ""])
    case.write_text(text)
    outs = {}
    for np_ in (None, 2):
        out = tmp_path / f"out{np_ or 1}"
        proc = run_cli(["run", case, "-o", out], np=np_, timeout=120)
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
        assert (out / "fields.xdmf").is_file() and (out / "fields.h5").is_file()
        outs[np_ or 1] = results(out)
    assert outs[1]["processes"] == 1 and outs[2]["processes"] == 2
    t1, t2 = outs[1]["tests"], outs[2]["tests"]
    assert len(t1) == len(t2) == 5
    for a, b in zip(t1, t2):
        assert a["name"] == b["name"]
        assert a["samples"] == b["samples"], a["name"]
        assert b["value"] == pytest.approx(a["value"], rel=1e-10, abs=1e-300), a["name"]
        assert a["ok"] and b["ok"]
    assert outs[1]["mesh"] == outs[2]["mesh"]
    assert outs[1]["dofs"] == outs[2]["dofs"]


@pytest.mark.parametrize("cell", ["QUAD8", "TRIA6"])
def test_affine_stiffness_equals_quadrature(cell):
    """The closed-form affine stiffness equals Gauss quadrature of B^T C B, for a batch of
    identical cells (the shared-Jacobian shortcut) and for distinct ones."""
    from xfemcontact.assembly import bulk
    from xfemcontact.fem import elasticity
    from xfemcontact.fem.elements import element, physical_gradients
    el = element(cell)
    D = hooke(2.0e5, 0.3, "C_PLAN")
    ps = bulk.PlainStiffness(el, D)
    base = el.ref_nodes.copy()
    shear = np.array([[1.3, 0.4], [-0.2, 0.9]])
    same = np.repeat((base @ shear.T)[None], 5, axis=0)
    rng = np.random.default_rng(7)
    distinct = np.stack([base @ (shear + 0.1 * rng.random((2, 2))).T + rng.random(2) for _ in range(5)])
    q, w = el.quadrature(4)
    for x in (same, distinct):
        J = el.jacobians(x, q)
        G, det = physical_gradients(el.dshape(q)[None], J)
        want = elasticity.stiffness(G, w[None] * det, elasticity.tensor(D))
        got = ps(x)
        assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()


@pytest.mark.parametrize("cell", ["QUAD8", "TRIA6"])
def test_affine_strains_equal_physical_gradients(cell):
    """Stresses of uncut cells: the affine path (reference gradients, one inverse
    Jacobian per cell) gives the points, weights and strains of the general one; curved
    cells are not taken for affine and keep the general path."""
    from xfemcontact.fem import elasticity
    from xfemcontact.fem.elements import element
    from xfemcontact.post import fields
    from xfemcontact.xfem import integration
    el = element(cell)
    rng = np.random.default_rng(3)
    base = el.ref_nodes.copy()
    cells = np.stack([base @ (np.array([[1.3, 0.4], [-0.2, 0.9]]) + 0.1 * rng.random((2, 2))).T + rng.random(2)
                      for _ in range(6)])
    ue = rng.standard_normal((6, 2 * el.nn))
    pts = integration.cell_points(el, cells, np.arange(6), np.ones(6))
    want = elasticity.strain(pts.dNdx, ue)
    x, w, eps = fields._affine_points(el, cells, ue)
    assert np.abs(eps - want).max() <= 1e-12 * np.abs(want).max()
    assert np.abs(x - pts.x).max() <= 1e-14 and np.abs(w - pts.w).max() <= 1e-14
    curved = cells.copy()
    curved[:, el.nv] += 0.05                  # a mid-edge node off its edge: not affine
    from xfemcontact.fem.elements import affine_cells
    assert not affine_cells(el, curved[:1]).any()
    x2, w2, eps2 = fields._curved_points(el, curved, ue)
    pts2 = integration.cell_points(el, curved, np.arange(6), np.ones(6))
    assert np.allclose(eps2, elasticity.strain(pts2.dNdx, ue), rtol=0, atol=1e-12)
    assert np.abs(eps2 - want).max() > 1e-3   # the curved cells really differ


def quadrature_mean_strains(model):
    """Area-weighted mean strain of every cell from the stresses at quadrature points."""
    nc = len(model.mesh.cells)
    area, eps = np.zeros(nc), np.zeros((nc, 3))
    for v in model.stresses():
        area += np.bincount(v.cells, v.w.sum(axis=1), minlength=nc)
        we = np.einsum("kq,kqi->ik", v.w, v.strain)
        for i in range(3):
            eps[:, i] += np.bincount(v.cells, we[i], minlength=nc)
    return eps / area[:, None]


@pytest.mark.parametrize("mesh", ["structured", "distorted"])
@pytest.mark.parametrize("cell", ["QUAD8", "TRIA6"])
def test_cell_mean_strains_equal_quadrature_means(tmp_path, cell, mesh):
    """The post mesh's cell strains (closed form on affine cells, quadrature on the others)
    are the means of the strains at the quadrature points, on a quadratic field."""
    from xfemcontact.post import fields
    s0, sx, sy, body = quadratic_stress()
    text = case_text(cell, dirichlet=[(SIDES, fmt(*P[:3], P[3:]), fmt(*Q[:3], Q[3:]))], body=body)
    m = solve(tmp_path, text, MESHES_LINEAR[mesh](cell))
    got = fields.cell_mean_strains(m.mesh, m.geo, m.layout, m.local_solution())
    want = quadrature_mean_strains(m)
    assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()
    assert np.ptp(want[:, 0]) > 1e-3 * np.abs(want).max()      # the cells really differ


@pytest.mark.parametrize("cell", ["QUAD8", "TRIA6"])
def test_linear_reference_inverts_the_companion_map(cell):
    """``linear_reference`` maps physical points back to reference coordinates, inside
    and outside distorted cells (the weak-vertex extrapolation evaluates a root cell's
    P1 / Q1 functions at a vertex of a neighbouring cell)."""
    from xfemcontact.fem.elements import Quad8, Tria6

    el = Quad8() if cell == "QUAD8" else Tria6()
    rng = np.random.default_rng(7)
    k = 50
    xv = el.ref_nodes[: el.nv][None] * 0.5 + rng.uniform(-0.08, 0.08, (k, el.nv, 2))
    xv = xv @ np.array([[np.cos(0.4), np.sin(0.4)], [-np.sin(0.4), np.cos(0.4)]]) + [3.0, -2.0]
    xi = rng.uniform(-2.0, 2.0, (k, 2)) if cell == "QUAD8" else rng.uniform(-1.0, 2.0, (k, 2))
    x = np.einsum("ka,kai->ki", el.shape_linear(xi), xv)
    back = el.linear_reference(xv, x)
    assert np.allclose(np.einsum("ka,kai->ki", el.shape_linear(back), xv), x, atol=1e-12)
    assert np.allclose(back, xi, atol=1e-9)
