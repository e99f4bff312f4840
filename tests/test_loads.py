"""Loads on edges and cells the interface cuts: the assembled load vector against the
same integrals computed independently (each boundary edge split at the exact zero of
LN along it, each cut cell clipped by the straight interface), and the validation
cases that load cut boundary edges (issue 18, point 3).

An edge the interface crosses is loaded on each side: its Heaviside functions
psi_a N_a (psi_a = H - H(x_a)) get the traction of the other side's piece only.
Before the edges were split with the crossing their cells are cut at, an edge whose
quadratic LN has its second root below -1 (a curved LN, or on Gmsh meshes a straight
one, the mid-node being off the middle by round-off) was loaded on one side only.
"""
import numpy as np
import pytest
from scipy.optimize import brentq

from conftest import CASES, MESHES, results, run_cli, write_case
from xfemcontact.assembly import system
from xfemcontact.case import load_case
from xfemcontact.fem.elements import Seg3
from xfemcontact.fem.quadrature import gauss_segment, gauss_triangle
from xfemcontact.model import Model
from xfemcontact.xfem.levelset import edge_roots

LINE = "y - 0.3*x - 4.1"
CIRCLE = "(x-5)**2 + (y-11.77)**2 - 64.27"
LEVEL_SET = {"line": LINE, "circle": CIRCLE}
MESH = {
    "gmsh TRIA6": f'file = "{MESHES / "gmsh_tria6.msh"}"',
    "gmsh QUAD8": f'file = "{MESHES / "gmsh_quad8.msh"}"',
    "TRIA6 20x20": 'rectangle = { nx = 20, ny = 20, x = [0.0, 10.0], y = [0.0, 10.0], cell = "TRIA6" }',
    "QUAD8 20x20": 'rectangle = { nx = 20, ny = 20, x = [0.0, 10.0], y = [0.0, 10.0], cell = "QUAD8" }',
    "jittered TRIA6": f'file = "{MESHES / "ssnv509_jittered.msh"}"',
}
#: outward unit normals of the edge groups of the square
NORMAL = {"LIG1": (0.0, -1.0), "LIG2": (1.0, 0.0), "LIG3": (0.0, 1.0), "LIG4": (-1.0, 0.0)}
GROUPS = list(NORMAL)
FX, FY, PRES = "1 + 0.1*y", "-2 + 0.05*x*y", "3 + 0.2*y - 0.1*x"
BX, BY = "0.5 + 0.1*x", "-2 + 0.2*y"


def ln_function(text):
    return {LINE: lambda x, y: y - 0.3 * x - 4.1,
            CIRCLE: lambda x, y: (x - 5) ** 2 + (y - 11.77) ** 2 - 64.27}[text]


def model(tmp_path, mesh, level_set, loads):
    path = write_case(tmp_path, f"""
        [mesh]
        {MESH[mesh]}

        [material]
        E = 1.0e6
        nu = 0.25

        [[dirichlet]]
        group = "LIG1"
        DX = 0.0
        DY = 0.0

        [interface]
        level_set = "{level_set}"

        [contact]
        coulomb = 1.0
        seuil_init = -1.0
        """ + loads)
    return Model(load_case(path))


def assembled(m, traction=True, body=False):
    """Load vector of the case's tractions or body force at the nodes: ``(u (n, 2), h (n, 2))``
    on the functions N_a and psi_a N_a (h = 0 where a node has no Heaviside dofs)."""
    layout = m.layout
    f = layout.local_array()
    if traction:
        system.add_tractions(m.mesh, m.geo, layout, m.case.traction, f)
    if body:
        system.add_body_forces(m.mesh, m.geo, layout, m.case.body_force, f)
    n = len(m.mesh.x)
    return f[layout.u_local[:n]], np.where(layout.h_local >= 0, f[layout.h_local], 0.0)


def exact_edge_loads(m, ln, traction):
    """The same, integrated independently: every edge of the four groups split at the zero
    of ``ln`` along it (found by bracketing), 12 Gauss points per piece, H of each piece
    from the sign of ``ln`` at its middle.  ``traction(group, x (nq, 2)) -> (nq, 2)``."""
    mesh, geo = m.mesh, m.geo
    u, h = np.zeros((len(mesh.x), 2)), np.zeros((len(mesh.x), 2))
    q, w = gauss_segment(12)
    crossed = 0
    for g in GROUPS:
        nodes, _, _ = mesh.group_edges(g)
        for e in nodes:
            xe = mesh.x[e]
            def f(s):
                return ln(*(Seg3.shape(s) @ xe))
            cuts = [-1.0, 1.0]
            if f(-1.0) * f(1.0) < 0:
                cuts.insert(1, brentq(f, -1.0, 1.0, xtol=1e-15))
                crossed += 1
            for a, b in zip(cuts[:-1], cuts[1:]):
                s = 0.5 * (a + b) + 0.5 * (b - a) * q[:, 0]
                N = Seg3.shape(s)
                ds = np.linalg.norm(Seg3.dshape(s) @ xe, axis=1)
                side = 1.0 if f(0.5 * (a + b)) > 0 else -1.0
                fe = np.einsum("q,qi,qa->ai", 0.5 * (b - a) * w * ds, traction(g, N @ xe), N)
                u[e] += fe
                h[e] += fe * ((side - geo.node_side[e]) * geo.enriched[e])[:, None]
    return u, h, crossed


def force_traction(g, x):
    return np.c_[1 + 0.1 * x[:, 1], -2 + 0.05 * x[:, 0] * x[:, 1]]


def pressure_traction(g, x):
    return -(3 + 0.2 * x[:, 1] - 0.1 * x[:, 0])[:, None] * np.array(NORMAL[g])


TRACTIONS = {
    "FORCE_CONTOUR": (f'[[traction]]\ngroup = {GROUPS}\nFX = "{FX}"\nFY = "{FY}"\n', force_traction),
    "PRES_REP": (f'[[traction]]\ngroup = {GROUPS}\nPRES = "{PRES}"\n', pressure_traction),
}


@pytest.mark.parametrize("kind", list(TRACTIONS))
@pytest.mark.parametrize("mesh, shape", [("gmsh TRIA6", "line"), ("gmsh QUAD8", "line"),
                                         ("TRIA6 20x20", "circle"), ("QUAD8 20x20", "circle"),
                                         ("TRIA6 20x20", "line"), ("jittered TRIA6", "line")])
def test_tractions_on_cut_edges(tmp_path, mesh, shape, kind):
    """Tractions (FX/FY and pressure, varying along the edges) on the four edges of the
    square, two of which the interface crosses: both the standard and the Heaviside
    parts of the load vector are the exact integrals.  On the Gmsh meshes (straight
    interface, mid-nodes off by round-off) and on the structured ones with the SSNV509
    circle (left edge) the crossing was missed before and the Heaviside part of the
    crossed edge's nodes was off by the other side's share."""
    text, traction = TRACTIONS[kind]
    level_set = LEVEL_SET[shape]
    m = model(tmp_path, mesh, level_set, text)
    u, h = assembled(m)
    u_ref, h_ref, crossed = exact_edge_loads(m, ln_function(level_set), traction)
    assert crossed == 2
    assert np.abs(h_ref).max() > 0.1 * np.abs(u_ref).max()       # the test sees the Heaviside part
    scale = np.abs(u_ref).max()
    assert np.abs(u - u_ref).max() < 1e-12 * scale
    assert np.abs(h - h_ref).max() < 1e-12 * scale, np.abs(h - h_ref).max() / scale


def _clip(poly, ln, sign):
    """Part of the convex polygon ``poly (k, 2)`` where ``sign * ln >= 0`` (``ln`` linear)."""
    out = []
    for p, q in zip(poly, np.roll(poly, -1, axis=0)):
        fp, fq = sign * ln(*p), sign * ln(*q)
        if fp >= 0:
            out.append(p)
        if fp * fq < 0:
            out.append(p + fp / (fp - fq) * (q - p))
    return np.array(out)


def _reference_coordinates(el, xc, x):
    """Reference coordinates of the physical points ``x (m, 2)`` in the cell ``xc``
    (Newton on the isoparametric map)."""
    xi = np.tile(el.ref_nodes[: el.nv].mean(axis=0), (len(x), 1))
    for _ in range(50):
        r = el.shape(xi) @ xc - x
        J = np.einsum("an,mai->mni", xc, el.dshape(xi))     # dx_n / dxi_i
        step = np.linalg.solve(J, r[..., None])[..., 0]
        xi -= step
        if np.abs(step).max() < 1e-15:
            break
    return xi


def exact_body_loads(m, ln, body):
    """Body force ``body(x (m, 2)) -> (m, 2)`` on N_a and psi_a N_a, integrated
    independently: every cell with an enriched node clipped by the straight interface,
    each side fanned into triangles with a degree-12 rule."""
    mesh, geo = m.mesh, m.geo
    el = mesh.element
    u, h = np.zeros((len(mesh.x), 2)), np.zeros((len(mesh.x), 2))
    zeta, wz = gauss_triangle(12)
    for c, nodes in enumerate(mesh.cell_nodes):
        if not geo.enriched[nodes].any():
            continue
        xc = mesh.x[nodes]
        for side in (-1.0, 1.0):
            piece = _clip(xc[: el.nv], ln, side)
            for k in range(1, len(piece) - 1):
                tri = piece[[0, k, k + 1]]
                area2 = np.cross(tri[1] - tri[0], tri[2] - tri[0])
                if area2 <= 0:
                    continue
                x = tri[0] + zeta[:, :1] * (tri[1] - tri[0]) + zeta[:, 1:] * (tri[2] - tri[0])
                N = el.shape(_reference_coordinates(el, xc, x))
                fe = np.einsum("q,qi,qa->ai", wz * area2, body(x), N)
                u[nodes] += fe
                h[nodes] += fe * ((side - geo.node_side[nodes]) * geo.enriched[nodes])[:, None]
    return u, h


@pytest.mark.parametrize("mesh, tol", [("gmsh TRIA6", 1e-12), ("gmsh QUAD8", 1e-8),
                                       ("TRIA6 20x20", 1e-12), ("QUAD8 20x20", 1e-12)])
def test_body_force_on_cut_cells(tmp_path, mesh, tol):
    """A body force varying in x and y on the cut cells: standard and Heaviside parts of
    the load vector are the exact integrals of N_a f and psi_a N_a f over the cells
    (on the Gmsh quadrangles, which are not parallelograms, N_a is rational and both
    rules approximate)."""
    m = model(tmp_path, mesh, LINE, f'[body_force]\nFX = "{BX}"\nFY = "{BY}"\n')
    u, h = assembled(m, traction=False, body=True)

    def body(x):
        return np.c_[0.5 + 0.1 * x[:, 0], -2 + 0.2 * x[:, 1]]
    u_ref, h_ref = exact_body_loads(m, ln_function(LINE), body)
    enriched = m.geo.enriched
    scale = np.abs(u_ref).max()
    assert np.abs(h_ref).max() > 0.1 * scale
    assert np.abs(u - u_ref)[enriched].max() < tol * scale
    assert np.abs(h - h_ref).max() < tol * scale, np.abs(h - h_ref).max() / scale


def test_edge_roots_inside_first():
    """The root inside an edge comes first whichever side the quadratic's other root
    lies on (before, a root outside on the left came first, as NaN)."""
    # other root at -4.56 (left) and +4.56 (right); a straight LN with its mid-node value
    # off by round-off (other root near -/+ 1e12)
    roots = edge_roots(*ONE_CROSSING)
    assert np.allclose(roots[:, 0], ONE_CROSSING_ROOT, rtol=0, atol=1e-12)
    assert np.isnan(roots[:, 1]).all()
    # two roots inside: sorted; none: NaN
    r = edge_roots(np.array([1.0, 1.0]), np.array([1.0, 2.0]), np.array([-1.0, 3.0]))
    assert r[0, 0] < r[0, 1] and np.isnan(r[1]).all()


def test_edge_crossing():
    """The crossing of edges whose vertices have opposite signs, NaN on the others."""
    from xfemcontact.xfem.levelset import edge_crossing

    assert np.allclose(edge_crossing(*ONE_CROSSING), ONE_CROSSING_ROOT, rtol=0, atol=1e-12)
    assert np.isnan(edge_crossing(np.array([1.0]), np.array([1.0]), np.array([-1.0]))).all()


#: LN at the vertices and mid-node of edges crossed once, and the crossing
ONE_CROSSING = (np.array([-0.1, 0.4, -0.1, -0.1, 0.4]), np.array([0.4, -0.1, 0.4, 0.4, -0.1]),
                np.array([0.1, 0.1, 0.15 - 5.4e-14, 0.15 + 5.4e-14, 0.15 - 5.4e-14]))
ONE_CROSSING_ROOT = np.array([(-5 + np.sqrt(17)) / 2, (5 - np.sqrt(17)) / 2, -0.6, -0.6, 0.6])


VALIDATION = ["cut_edge_tractions_tria6", "cut_edge_column_tria6", "cut_edge_tractions_quad8",
              "cut_edge_circle_quad8"]


@pytest.mark.parametrize("name", VALIDATION)
def test_cut_edge_validation_cases(tmp_path, name):
    """Closed-form cases loaded through cut boundary edges (Gmsh meshes, and the SSNV509
    circle on a structured one): every test OK.  Before, LAGS_C was 123 / 10 / 115 Pa
    off where the straight interface leaves through x = 10, and 1.8e-3 Pa (2 %) where
    the circle leaves through x = 0."""
    out = tmp_path / name
    p = run_cli(["run", CASES / "validation" / f"{name}.toml", "-o", out])
    assert p.returncode == 0, p.stdout + p.stderr
    r = results(out)
    assert r["converged"] and all(t["ok"] for t in r["tests"]), r["tests"]
