"""X-FEM geometry of the SSNV509 circular interface: side areas, interface length,
int n ds and their convergence under refinement; the enrichment rule.

LN = (x - 5)^2 + (y - 11.77)^2 - 64.27 on [0, 10]^2.  LN < 0 ("-" side) is the
part of the square inside the circle, above its lower arc; LN > 0 ("+") is the
part below the arc.  LN is a quadratic polynomial, so both QUAD8 (serendipity,
x^2 and y^2 are in the space) and TRIA6 interpolate it exactly: the only
geometric error is the quadratic (SEG3) representation of the arc in each cut
cell, O(h^3) pointwise and O(h^4) for areas and length (odd error terms cancel).

Exact values (R^2 = 64.27, yc = 11.77, F(u) = (u sqrt(R^2 - u^2) + R^2 asin(u/R)) / 2
the antiderivative of sqrt(R^2 - u^2)):

* area of the "-" side = int_0^10 [10 - (yc - sqrt(R^2 - (x-5)^2))] dx
                       = 2 F(5) - 10 (yc - 10);  "+" side = 100 - that;
* interface length = R * 2 asin(5 / R) = 10.797891203332386;
* int n ds with n = grad LN / |grad LN| (outward from the circle).  Every
  interface segment is oriented with the + side on its left and n is its left
  normal, so n ds = rot(dx) with rot(v) = (-v_y, v_x), and int n ds telescopes
  to rot(end - start) along the chain of segments.  The + side (below the arc)
  is on the left when walking in -x, so the chain runs from C = (10, yA) to
  A = (0, yA), yA = yc - sqrt(R^2 - 25):  int n ds = rot(A - C) = rot((-10, 0))
  = (0, -10) (pointing down, out of the circle, as expected on its lower arc).
  This is exact for the discrete interface too: on affine cells dx/ds is linear
  on each SEG3 segment (4 Gauss points integrate it exactly) and the end points
  on x = 0 and x = 10 are roots of the edge quadratic, on which LN (quadratic
  in y there) is interpolated exactly.
"""
import math

import numpy as np
import pytest

from tests.conftest import MESHES
from xfemcontact.mesh import plex
from xfemcontact.mesh.generate import rectangle
from xfemcontact.mesh.read import read_mesh
from xfemcontact.mesh.refine import refine_uniform
from xfemcontact.xfem import geometry, integration
from xfemcontact.xfem.cut import TRI6, subcell_jacobians

XC, YC, R2 = 5.0, 11.77, 64.27
R = math.sqrt(R2)
LENGTH = 10.797891203332386


def _F(u):
    """Antiderivative of sqrt(R^2 - u^2)."""
    return 0.5 * (u * math.sqrt(R2 - u * u) + R2 * math.asin(u / R))


def exact_areas():
    """(area of the - side, area of the + side) of [0, 10]^2."""
    # the lower arc crosses x = 0 and x = 10 inside the square, stays above y = 0,
    # and the upper arc is above y = 10: the - side is {y >= arc} exactly
    assert YC - R > 0 and 0 < YC - math.sqrt(R2 - 25) < 10 and YC + R > 10 and R > 5
    minus = 2 * _F(5.0) - 10 * (YC - 10)
    return minus, 100.0 - minus


def phi_ssnv509(mesh):
    x, y = mesh.x[:, 0], mesh.x[:, 1]
    return (x - XC) ** 2 + (y - YC) ** 2 - R2


def side_areas(mesh, geo):
    """Sum of the quadrature weights by side over every cell (sub-cells for cut cells)."""
    areas = {-1: 0.0, 1: 0.0}
    wmin = np.inf
    for pts in geometry.cell_points(mesh, geo, np.arange(len(mesh.cells))):
        for s in (-1, 1):
            areas[s] += float(pts.w[pts.side == s].sum())
        live = pts.side != 0
        wmin = min(wmin, float(pts.w[live].min()))
        assert np.all(np.isfinite(pts.w)) and np.all(np.isfinite(pts.x))
    return areas, wmin


def interface_points(mesh, geo, order=4):
    segs = geo.segments()
    return integration.segment_points(mesh.element, mesh.x[mesh.cell_nodes[segs.cells]], segs, order)


def study(raw):
    """Geometry of the SSNV509 circle on ``raw``: a dict of measured quantities."""
    mesh = plex.load(raw)
    geo = geometry.build(mesh, phi_ssnv509(mesh))
    areas, wmin = side_areas(mesh, geo)
    sp = interface_points(mesh, geo)
    # sub-cell Jacobians at the TRIA6 check points (nodes + Gauss points)
    det = subcell_jacobians(geo.subcells.nodes, TRI6.check_points)
    live = geo.subcells.side != 0
    return dict(mesh=mesh, geo=geo, areas=areas, wmin=wmin, pts=sp,
                length=float(sp.w.sum()), nds=np.einsum("kq,kqi->i", sp.w, sp.normal),
                det_min=float(det[live].min()), cells=len(mesh.cells),
                cut=int(len(geo.subcells.cells)))


def ssnv509b():
    return read_mesh(MESHES / "ssnv509b.mmed")


MESH_BUILDERS = {
    "QUAD8 20x20": lambda: rectangle(20, 20),
    "QUAD8 40x40": lambda: rectangle(40, 40),
    "TRIA6 ssnv509b (800)": ssnv509b,
}
# area / length error bounds C h^4 (h = 0.5 or 0.25 m); measured values are 3-30 x smaller
H = {"QUAD8 20x20": 0.5, "QUAD8 40x40": 0.25, "TRIA6 ssnv509b (800)": 0.5}


@pytest.fixture(scope="module")
def studies():
    return {name: study(build()) for name, build in MESH_BUILDERS.items()}


@pytest.mark.parametrize("name", list(MESH_BUILDERS))
def test_ssnv509_areas_length_normal(studies, name):
    st = studies[name]
    minus, plus = exact_areas()
    a = st["areas"]
    h4 = H[name] ** 4
    err_m, err_p = a[-1] - minus, a[1] - plus
    err_l = st["length"] - LENGTH
    print(f"\n{name}: {st['cells']} cells, {st['cut']} cut; area(-) {a[-1]:.15f} (err {err_m:+.3e}), "
          f"area(+) {a[1]:.15f} (err {err_p:+.3e}), total - 100 = {a[-1] + a[1] - 100:+.1e}, "
          f"length {st['length']:.15f} (err {err_l:+.3e}), int n ds = ({st['nds'][0]:+.2e}, "
          f"{st['nds'][1]:.15f})")
    assert abs(a[-1] + a[1] - 100.0) <= 1e-12
    assert abs(err_m) <= 1e-4 * h4 and abs(err_p) <= 1e-4 * h4
    assert abs(err_l) <= 1e-5 * h4
    # int n ds = rot(A - C) = (0, -10), exact up to round-off (see the module docstring)
    np.testing.assert_allclose(st["nds"], [0.0, -10.0], rtol=0, atol=1e-12)
    # the normal is grad LN / |grad LN| (from - to +) at every interface point
    x = st["pts"].x
    g = np.stack([2 * (x[..., 0] - XC), 2 * (x[..., 1] - YC)], axis=-1)
    g /= np.linalg.norm(g, axis=-1, keepdims=True)
    cos = np.einsum("kqi,kqi->kq", g, st["pts"].normal)
    assert cos.min() > 1 - 1e-6
    # interface points lie on the circle (O(h^3) off it)
    dist = np.abs(np.hypot(x[..., 0] - XC, x[..., 1] - YC) - R)
    assert dist.max() <= 1e-3 * H[name] ** 3
    assert np.all(np.isfinite(st["pts"].w)) and np.all(st["pts"].w > 0)
    # the chain of segments starts and ends at A = (0, yA) and C = (10, yA)
    mesh, segs = st["mesh"], st["geo"].segments()
    ends = np.einsum("kpa,kai->kpi", mesh.element.shape(segs.nodes[:, :2]),
                     mesh.x[mesh.cell_nodes[segs.cells]]).reshape(-1, 2)
    ya = YC - math.sqrt(R2 - 25)
    np.testing.assert_allclose(ends[np.argmin(ends[:, 0])], [0.0, ya], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ends[np.argmax(ends[:, 0])], [10.0, ya], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", list(MESH_BUILDERS))
def test_ssnv509_subcells_positive(studies, name):
    """Every sub-cell has a positive Jacobian: at its check points and in its weights."""
    st = studies[name]
    geo = st["geo"]
    assert st["cut"] > 0 and (geo.cell_side == 0).sum() == st["cut"]
    assert st["det_min"] > 0
    assert st["wmin"] > 0
    # every cut cell has both sides
    side = geo.subcells.side
    assert np.all((side == -1).any(axis=1) & (side == 1).any(axis=1))
    assert geo.readjustment.lifted_edges == 0 and geo.dropped == 0


def _orders(h, e):
    h, e = np.asarray(h), np.abs(np.asarray(e))
    return np.log(e[:-1] / e[1:]) / np.log(h[:-1] / h[1:])


SEQUENCES = {
    "QUAD8 rectangles 20..160": [(10 / n, (lambda n=n: rectangle(n, n))) for n in (20, 40, 80, 160)],
    "TRIA6 ssnv509b refined 0..3": [(0.5 / 2 ** k, (lambda k=k: refine_uniform(ssnv509b(), k)))
                                    for k in range(4)],
}


@pytest.mark.parametrize("name", list(SEQUENCES))
def test_ssnv509_convergence(name):
    minus, plus = exact_areas()
    rows = []
    for h, build in SEQUENCES[name]:
        st = study(build())
        a = st["areas"]
        assert abs(a[-1] + a[1] - 100.0) <= 1e-12
        assert st["det_min"] > 0 and st["wmin"] > 0
        np.testing.assert_allclose(st["nds"], [0.0, -10.0], rtol=0, atol=1e-12)
        rows.append((h, st["cells"], a[-1] - minus, a[1] - plus, st["length"] - LENGTH,
                     a[-1] + a[1] - 100.0, abs(st["nds"][1] + 10) + abs(st["nds"][0])))
    h = [r[0] for r in rows]
    oa = _orders(h, [r[2] for r in rows])
    ol = _orders(h, [r[4] for r in rows])
    print(f"\n{name}: area and length errors against the exact circle")
    print(f"{'h':>8} {'cells':>6} {'area(-) err':>12} {'order':>6} {'area(+) err':>12} "
          f"{'length err':>12} {'order':>6} {'total-100':>9} {'|nds err|':>9}")
    for i, r in enumerate(rows):
        o1 = f"{oa[i - 1]:6.2f}" if i else " " * 6
        o2 = f"{ol[i - 1]:6.2f}" if i else " " * 6
        print(f"{r[0]:8.5f} {r[1]:6d} {r[2]:+12.3e} {o1} {r[3]:+12.3e} {r[4]:+12.3e} {o2} "
              f"{r[5]:+9.1e} {r[6]:9.1e}")
    assert np.all(oa >= 3.0), oa
    assert np.all(ol >= 3.0), ol


# -- enrichment rule ---------------------------------------------------------------
def test_enrichment_rule_ssnv509_quad8(studies):
    """A node is enriched iff the part of its support on the side opposite to it has a
    positive area (no node is dropped by the conditioning rule here); every node of a
    cut cell is enriched; nodes far from the interface are not."""
    st = studies["QUAD8 20x20"]
    mesh, geo = st["mesh"], st["geo"]
    n = len(mesh.x)
    assert geo.dropped == 0
    # opposite-side area of every node's support, from the quadrature weights
    opp = np.zeros(n)
    for pts in geometry.cell_points(mesh, geo, np.arange(len(mesh.cells))):
        nodes = mesh.cell_nodes[pts.cells]                                     # (k, nn)
        other = pts.side[:, :, None] != geo.node_side[nodes][:, None, :]        # (k, nq, nn)
        np.add.at(opp, nodes, np.einsum("kq,kqa->ka", pts.w, other * (pts.side != 0)[..., None]))
    expected = opp > 0
    np.testing.assert_array_equal(geo.enriched, expected)
    # node side: H(x_j) = +1 where LN >= 0
    np.testing.assert_array_equal(geo.node_side, np.where(geo.phi >= 0, 1, -1))
    # every node of a cut cell is enriched
    cut_nodes = np.unique(mesh.cell_nodes[geo.cell_side == 0])
    assert geo.enriched[cut_nodes].all()
    # nodes farther than two cell diagonals from the circle are not
    dist = np.abs(np.hypot(mesh.x[:, 0] - XC, mesh.x[:, 1] - YC) - R)
    far = dist > 2 * 0.5 * math.sqrt(2)
    assert far.sum() > 0.6 * n and not geo.enriched[far].any()
    # support ratios: in (0, 1] for enriched nodes, 1 elsewhere
    r = geo.ratio[geo.enriched]
    assert np.all((r > 0) & (r <= 1)) and np.all(geo.ratio[~geo.enriched] == 1.0)
    print(f"\nSSNV509 QUAD8 20x20: {int(geo.enriched.sum())} enriched nodes of {n} "
          f"({len(cut_nodes)} nodes of {st['cut']} cut cells), min support ratio "
          f"{r.min():.3e}, dropped {geo.dropped}")


def test_cell_max_at_nodes_is_the_scatter_max():
    """The sort-based scatter-max equals np.maximum.at, nodes of no cell stay 0."""
    from xfemcontact.xfem.levelset import cell_max_at_nodes
    rng = np.random.default_rng(3)
    cells = rng.integers(0, 50, size=(40, 6))
    values = rng.random(60)                    # nodes 50..59 belong to no cell
    want = np.zeros(60)
    for col in cells.T:
        np.maximum.at(want, col, values[cells].max(axis=1))
    got = cell_max_at_nodes(cells, values)
    np.testing.assert_array_equal(got, want)
    assert not got[50:].any()
    assert cell_max_at_nodes(np.zeros((0, 6), int), values).sum() == 0.0


# -- interfaces tangent to a mesh edge -----------------------------------------------
def _ellipse(xc, yc, a, b):
    """Level set of an ellipse and its lower arc y(x), y'(x)."""
    def low(x):
        return yc - b * np.sqrt(1 - ((x - xc) / a) ** 2)

    def slope(x):
        u = (x - xc) / a
        return b * u / (a * np.sqrt(1 - u * u))

    return (lambda x, y: ((x - xc) / a) ** 2 + ((y - yc) / b) ** 2 - 1), low, slope


#: curves whose lowest point lies on the mesh line y = 5 (circles of radius 8) or
#: y = 3.5 (the ellipse) of a 20 x 20 mesh (h = 0.5), by where they touch it.  A dip
#: of 3e-3 m below the line crosses one edge twice (readjustment rule 3).
TANGENT = {"at a vertex": _ellipse(5.0, 13.0, 8.0, 8.0),
           "at a mid-node": _ellipse(5.25, 13.0, 8.0, 8.0),
           "inside an edge": _ellipse(5.1, 13.0, 8.0, 8.0),
           "dipping below an edge": _ellipse(5.25, 12.997, 8.0, 8.0),
           "ellipse at a vertex": _ellipse(5.0, 11.0, 6.0, 7.5)}


def lower_arc_geometry(low, slope):
    """Exact area of the - side (above the lower arc) of [0, 10]^2 and the arc length."""
    from scipy.integrate import quad

    area = quad(lambda x: 10 - low(x), 0, 10, epsabs=1e-13, epsrel=1e-13)[0]
    length = quad(lambda x: math.sqrt(1 + slope(x) ** 2), 0, 10, epsabs=1e-13, epsrel=1e-13)[0]
    return area, length


@pytest.mark.parametrize("cell", ["QUAD8", "TRIA6"])
@pytest.mark.parametrize("kind", list(TANGENT))
def test_interface_tangent_to_a_mesh_edge(cell, kind):
    """A curve touching a row of cell edges is cut, with areas and length to the
    accuracy of the quadratic segments: at a node the tangency is kept (the sliver
    next to it may fold on less than ``cut.FOLD_AREA`` of its cell; zero-area fan
    triangles are dropped); inside an edge the zero line is pushed off that edge
    (rule 3), which moves the interface by about the clearance it then has."""
    ln, low, slope = TANGENT[kind]
    mesh = plex.load(rectangle(20, 20, cell=cell))
    geo = geometry.build(mesh, ln(mesh.x[:, 0], mesh.x[:, 1]))
    areas, wmin = side_areas(mesh, geo)
    length = float(interface_points(mesh, geo).w.sum())
    minus, exact_length = lower_arc_geometry(low, slope)
    r = geo.readjustment
    err_area, err_length = areas[-1] - minus, length - exact_length
    print(f"\n{cell} tangent {kind}: lifted {r.lifted_edges}, pushed off {r.pushed_off}, "
          f"area error {err_area:+.2e}, length error {err_length:+.2e}, min weight {wmin:.1e}")
    assert abs(areas[-1] + areas[1] - 100.0) <= 1e-11
    if "vertex" in kind or "mid-node" in kind:
        assert r.pushed_off == 0
        assert abs(err_area) < 2e-5 and abs(err_length) < 2e-5
    else:
        assert r.lifted_edges >= 1
        assert abs(err_area) < 2e-3 and abs(err_length) < 1e-3


# -- cells whose maps are not affine ----------------------------------------------------
def distorted(n, fraction, seed):
    """``n x n`` QUAD8 rectangle of [0, 10]^2 whose interior vertices are moved at random
    by up to ``fraction`` of h (straight-sided quadrangles, not parallelograms)."""
    raw = rectangle(n, n)
    rng = np.random.default_rng(seed)
    p, v = raw.points, raw.vertex_nodes
    inner = v[(p[v] > 1e-12).all(axis=1) & (p[v] < 10 - 1e-12).all(axis=1)]
    p[inner] += rng.uniform(-fraction * 10 / n, fraction * 10 / n, (len(inner), 2))
    for a, b, m in ((0, 1, 4), (1, 2, 5), (2, 3, 6), (3, 0, 7)):
        p[raw.cells[:, m]] = 0.5 * (p[raw.cells[:, a]] + p[raw.cells[:, b]])
    return raw


#: straight lines a x + b y = c and the area of [0, 10]^2 where a x + b y > c
LINES = {"horizontal": ((0.0, 1.0, 5.13), 100 - 51.3), "inclined": ((-0.3, 1.0, 3.1), 100 - (31 + 15))}


@pytest.mark.parametrize("line", list(LINES))
def test_straight_interface_on_distorted_quadrangles(line):
    """A straight interface across distorted QUAD8 cells stays straight: its Gauss points
    lie on the line, the normals are the line's, the areas and the length are exact.
    (With segments quadratic in the reference cell the points were 1.4e-3 m off the line
    and the normals 2.2e-2 rad off.)"""
    (a, b, c), plus = LINES[line]
    mesh = plex.load(distorted(20, 0.25, 7))
    geo = geometry.build(mesh, a * mesh.x[:, 0] + b * mesh.x[:, 1] - c)
    areas, wmin = side_areas(mesh, geo)
    sp = interface_points(mesh, geo)
    norm = math.hypot(a, b)
    assert wmin > 0
    assert np.abs(sp.x @ [a, b] - c).max() / norm < 1e-12
    np.testing.assert_allclose(sp.normal, np.broadcast_to([a / norm, b / norm], sp.normal.shape), atol=1e-12)
    assert abs(areas[1] - plus) < 1e-11 and abs(areas[-1] - (100 - plus)) < 1e-11
    assert abs(sp.w.sum() - 10 * norm / abs(b)) < 1e-12


def test_circle_on_distorted_quadrangles_converges():
    """The SSNV509 circle on distorted QUAD8 meshes: the length and the normals converge.
    The serendipity interpolant of LN is not exact on such cells, so the interface is off
    the circle by O(h^2) and its normal by about O(h).  (With segments quadratic in the
    reference cell the normal error stayed at 2e-2 .. 7e-2 rad from N = 20 to 160.)"""
    rows = []
    for n in (20, 40, 80):
        mesh = plex.load(distorted(n, 0.25, n))
        geo = geometry.build(mesh, phi_ssnv509(mesh))
        areas, wmin = side_areas(mesh, geo)
        sp = interface_points(mesh, geo)
        radial = (sp.x - [XC, YC]) / np.linalg.norm(sp.x - [XC, YC], axis=-1)[..., None]
        sin = np.abs(np.cross(sp.normal, radial))
        rows.append((10 / n, float(sp.w.sum()) - LENGTH, float(sin.max())))
        assert wmin > 0 and abs(areas[-1] + areas[1] - 100) < 1e-11
    h, dl, dn = (np.array(r) for r in zip(*rows))
    print("\ndistorted QUAD8 circle: h, length error, largest normal angle", rows)
    assert np.all(_orders(h, dl) > 1.8)
    assert np.all(dn[1:] < dn[:-1]) and dn[-1] < 2e-3


def test_inverse_map_of_distorted_and_affine_cells():
    """``Element.inverse_map`` recovers reference points of distorted QUAD8 cells to
    1e-13 and leaves an exact guess untouched (affine cells keep the composed points)."""
    from xfemcontact.fem.elements import element

    el = element("QUAD8")
    raw = distorted(4, 0.25, 1)
    xc = raw.points[raw.cells]                                                # (16, 8, 2)
    rng = np.random.default_rng(0)
    xi = rng.uniform(-1, 1, (len(xc), 30, 2))
    x = el.map_points(xc, xi)
    got, failed = el.inverse_map(xc, x, np.zeros_like(xi))
    assert not failed.any() and np.abs(got - xi).max() < 1e-13
    square = rectangle(4, 4).points[rectangle(4, 4).cells]
    same, failed = el.inverse_map(square, el.map_points(square, xi), xi)
    assert not failed.any() and np.array_equal(same, xi)


def test_segment_midpoint_falls_back_to_the_reference_bisector(monkeypatch):
    """When the physical bisector's zero is not found inside a cell, P3 is the zero of LN
    on the reference bisector (still on the interface) instead of an error."""
    from xfemcontact.fem.elements import element
    from xfemcontact.xfem import cut

    el = element("QUAD8")
    xc = distorted(1, 0.0, 0).points[distorted(1, 0.0, 0).cells]              # one 10 x 10 square
    phi = xc[..., 1] - 4.0 - 0.05 * xc[..., 0]                                # a line across it
    p1, p2 = np.array([[-1.0, -0.2]]), np.array([[1.0, -0.1]])
    good = cut.segment_midpoints(el, phi, xc, p1, p2, [0])
    monkeypatch.setattr(cut, "_physical_bisector", lambda *a: np.array([[5.0, 5.0]]))
    fallback = cut.segment_midpoints(el, phi, xc, p1, p2, [0])
    assert el.contains(fallback).all() and abs(cut.phi_at(el, phi, fallback)).max() < 1e-12
    assert np.allclose(fallback, good, atol=1e-12)        # a square: both bisectors agree
