"""3-D foundations: HEXA20 and TETRA10 beside QUAD8 and TRIA6.

Reference elements (partition of unity, Kronecker property, gradients, faces),
quadrature degrees, the box generator, reading 3-D meshes (MED, Gmsh, VTU), the
patch tests (a linear displacement reproduced to round-off through imposed
displacements, face tractions and pressures, on distorted hexahedra, generated
tetrahedra and an unstructured Gmsh mesh), a quadratic field reproduced exactly,
convergence orders on a smooth manufactured solution, one process against two,
and the refusals (bad box keys, unsupported 3-D cells).
"""
import math

import meshio
import numpy as np
import pytest

from conftest import MESHES, ROOT, results, run_cli, write_case
from xfemcontact.case import load_case
from xfemcontact.errors import CaseError, MeshError
from xfemcontact.fem import elasticity, quadrature
from xfemcontact.fem.elements import element, physical_gradients, surface_geometry
from xfemcontact.mesh.generate import box
from xfemcontact.mesh.read import from_meshio, read_mesh

SOLIDS = ("HEXA20", "TETRA10")
ALL = ("QUAD8", "TRIA6") + SOLIDS
E, NU = 2.0e5, 0.3


# -- reference elements ---------------------------------------------------------------
def random_points(el, n=40, seed=0):
    """Points inside the reference element ``el``."""
    xi = np.random.default_rng(seed).random((n, el.dim))
    if el.name in ("TRIA6", "TETRA10"):
        xi *= 0.9 / xi.sum(axis=1, keepdims=True).clip(1.0)
    else:
        xi = 2 * xi - 1
    return xi


@pytest.mark.parametrize("name", ALL)
def test_partition_of_unity_and_kronecker(name):
    el = element(name)
    assert el.ref_nodes.shape == (el.nn, el.dim)
    assert np.allclose(el.shape(el.ref_nodes), np.eye(el.nn), atol=1e-15)
    xi = random_points(el)
    assert np.allclose(el.shape(xi).sum(axis=-1), 1.0, atol=1e-14)
    assert np.allclose(el.dshape(xi).sum(axis=-2), 0.0, atol=1e-13)
    assert np.allclose(el.shape_linear(el.ref_nodes[:el.nv]), np.eye(el.nv), atol=1e-15)
    # the element reproduces every polynomial of degree 2: x_i x_j interpolated exactly
    X = el.ref_nodes
    for i in range(el.dim):
        for j in range(i, el.dim):
            assert np.allclose(el.shape(xi) @ (X[:, i] * X[:, j]), xi[:, i] * xi[:, j], atol=1e-14)


@pytest.mark.parametrize("name", ALL)
def test_gradients_match_finite_differences(name):
    el = element(name)
    xi = random_points(el, seed=1)
    h = 1e-6
    for k in range(el.dim):
        step = h * np.eye(el.dim)[k]
        fd = (el.shape(xi + step) - el.shape(xi - step)) / (2 * h)
        assert np.allclose(fd, el.dshape(xi)[..., k], atol=1e-8)
        fd = (el.shape_linear(xi + step) - el.shape_linear(xi - step)) / (2 * h)
        assert np.allclose(fd, el.dshape_linear(xi)[..., k], atol=1e-8)


@pytest.mark.parametrize("name", SOLIDS)
def test_faces_are_outward_and_follow_the_edges(name):
    """Each face lists its vertices with the outward normal by the right-hand rule,
    then the mid-edge nodes of its consecutive vertices, as its own element (QUAD8,
    TRIA6) orders them; the reference cell has a positive Jacobian."""
    el = element(name)
    face = element(el.face_type)
    X = el.ref_nodes
    centre = X[:el.nv].mean(axis=0)
    mid = {frozenset(e[:2]): e[2] for e in el.edges.tolist()}
    for f in el.faces:
        v = f[:face.nv]
        assert [mid[frozenset((v[k], v[(k + 1) % face.nv]))] for k in range(face.nv)] == list(f[face.nv:])
        _, _, n = surface_geometry(face, X[f][None], face.ref_nodes)
        assert np.all(np.einsum("qi,qi->q", n[0], X[f] - centre) > 0)
    assert (el.jacobian_dets(X[None], el.check_points) > 0).all()
    # reverse mirrors the cell: the Jacobian changes sign
    assert (el.jacobian_dets(X[el.reverse][None], el.check_points) < 0).all()


def test_quadrature_degrees():
    """The tetrahedron rules are exact to their degree on every monomial; the cube's
    n-point tensor rule to degree 2n - 1 in each variable, not 2n."""
    for degree in range(1, 8):
        p, w = quadrature.gauss_tetrahedron(degree)
        assert (w > 0).all()
        for a in range(degree + 1):
            for b in range(degree + 1 - a):
                for c in range(degree + 1 - a - b):
                    exact = math.factorial(a) * math.factorial(b) * math.factorial(c) / math.factorial(a + b + c + 3)
                    assert abs(w @ (p[:, 0] ** a * p[:, 1] ** b * p[:, 2] ** c) - exact) < 1e-15
    def segment(a):                       # integral of t^a over [-1, 1]
        return 0.0 if a % 2 else 2.0 / (a + 1)

    for n in range(1, 5):
        p, w = quadrature.gauss_cube(n)
        top = 2 * n - 1
        for a, b, c in np.ndindex(top + 1, top + 1, top + 1):
            exact = segment(a) * segment(b) * segment(c)
            assert abs(w @ (p[:, 0] ** a * p[:, 1] ** b * p[:, 2] ** c) - exact) < 1e-13
        assert abs(w @ p[:, 0] ** (2 * n) - segment(2 * n) * 4) > 1e-6     # degree 2n: not exact


@pytest.mark.parametrize("name", SOLIDS)
def test_stiffness_kernel(name):
    """Six rigid modes, no more, in the kernel of a distorted cell's stiffness; the
    affine closed form equals the quadrature on a parallelepiped."""
    from xfemcontact.assembly.bulk import PlainStiffness

    el = element(name)
    D = elasticity.hooke(E, NU, "3D")
    rng = np.random.default_rng(3)
    A = np.eye(3) + 0.3 * rng.random((3, 3))
    x = (el.ref_nodes @ A.T)[None]
    K = PlainStiffness(el, D)
    q, w = el.quadrature(6)
    G, det = physical_gradients(el.dshape(q)[None], el.jacobians(x, q))
    assert np.allclose(K(x.copy()), elasticity.stiffness(G, w * det, elasticity.tensor(D)), rtol=0, atol=1e-11 * E)
    xd = x + 0.04 * rng.standard_normal(x.shape)
    Kd = K(xd)[0]
    modes = [np.repeat(t, el.nn) for t in np.eye(3)] + [np.cross(a, xd[0]).T.ravel() for a in np.eye(3)]
    assert np.abs(Kd @ np.array(modes).T).max() < 1e-10 * np.abs(Kd).max()
    assert np.sum(np.linalg.eigvalsh(Kd) < 1e-8 * np.abs(Kd).max()) == 6


# -- box generator -----------------------------------------------------------------------
@pytest.mark.parametrize("name,per,nodes", [("HEXA20", 1, lambda n: (n + 1) ** 3 + 3 * n * (n + 1) ** 2),
                                            ("TETRA10", 6, lambda n: (2 * n + 1) ** 3)])
def test_box(name, per, nodes):
    n = 3
    m = box(n, n, n, x=(0, 1), y=(0, 2), z=(-1, 1), cell=name)
    assert m.cells.shape == (per * n ** 3, element(name).nn) and len(m.points) == nodes(n)
    el = element(name)
    q, w = el.quadrature(4)
    vol = el.jacobian_dets(m.points[m.cells], q) @ w
    assert (vol > 0).all() and abs(vol.sum() - 4.0) < 1e-12
    m.check()                                  # valid: nothing to re-orient
    face = element(el.face_type)
    qf, wf = face.quadrature(4)
    areas = {"left": 4, "right": 4, "front": 2, "back": 2, "bottom": 2, "top": 2}
    normals = {"left": (-1, 0, 0), "right": (1, 0, 0), "front": (0, -1, 0), "back": (0, 1, 0),
               "bottom": (0, 0, -1), "top": (0, 0, 1)}
    for g, area in areas.items():
        _, da, nrm = surface_geometry(face, m.points[m.face_groups[g]], qf)
        assert abs((da @ wf).sum() - area) < 1e-12
        assert np.allclose(nrm, normals[g])
    assert np.array_equal(m.face_groups["SURFINF"], m.face_groups["bottom"])
    assert np.array_equal(m.face_groups["SURFSUP"], m.face_groups["top"])
    assert list(m.cell_groups) == ["VOL"]
    assert np.allclose(m.points[m.node_groups["P7"][0]], (1, 2, 1))
    # conforming: every face of a cell is on the boundary or shared by exactly two cells
    nvf = face.nv
    keys = np.sort(m.cells[:, el.faces[:, :nvf]].reshape(-1, nvf), axis=1)
    _, count = np.unique(keys, axis=0, return_counts=True)
    assert set(count.tolist()) <= {1, 2}
    assert (count == 1).sum() == sum(len(m.face_groups[g]) for g in areas)


def test_box_refusals(tmp_path):
    for kwargs, words in (({"nz": 0}, "nz must be a positive integer"),
                          ({"cell": "QUAD8"}, "cell must be one of HEXA20, TETRA10"),
                          ({"z": (1.0, 0.0)}, "z must be an interval")):
        args = dict(nx=1, ny=1, nz=1)
        args.update(kwargs)
        with pytest.raises(MeshError, match=words):
            box(**args)
    base = """
        [mesh]
        box = {{{box}}}
        [material]
        E = 1e5
        nu = 0.3
        {model}
        [[dirichlet]]
        group = "bottom"
        DX = 0
        DY = 0
        DZ = 0
        """
    for spec, model, expected in (
            ("nx = 2, ny = 2", "", "mesh.box.nz: missing required key"),
            ("nx = 2, ny = 2, nz = 2, nw = 3", "", "mesh.box.nw: unknown key (did you mean 'nx'?)"),
            ("nx = 2, ny = 2, nz = 2, cell = \"QUAD8\"", "", "mesh.box.cell: unknown value \"QUAD8\""),
            ("nx = 2, ny = 2, nz = 2, z = [1, 0]", "", "mesh.box.z: must be increasing"),
            ("nx = 2, ny = 2, nz = 2.5", "", "mesh.box.nz: expected an integer"),
            ("nx = 2, ny = 2, nz = 2", 'model = "C_PLAN"', "material.model: mesh.box is a 3-D mesh")):
        path = write_case(tmp_path, base.format(box=spec, model=model))
        with pytest.raises(CaseError) as exc:
            load_case(path)
        assert str(exc.value).startswith(f"{path}: {expected}"), str(exc.value)
        assert "\n" not in str(exc.value)


# -- reading -----------------------------------------------------------------------------
def test_read_gmsh_tetra10():
    """The unstructured Gmsh file of cases/meshes/jittered_tetra10.py: cells read back in
    code_aster's order (positive Jacobians), its volume and face groups."""
    m = read_mesh(MESHES / "jittered_tetra10.msh")
    el = element("TETRA10")
    assert m.cell_type == "TETRA10" and m.dim == 3 and len(m.cells) > 500
    q, w = el.quadrature(2)
    det = el.jacobian_dets(m.points[m.cells], q)
    assert (det > 0).all() and abs((det @ w).sum() - 2.0) < 1e-12
    assert sorted(m.face_groups) == ["back", "bottom", "front", "left", "right", "top"]
    assert list(m.cell_groups) == ["VOL"]


@pytest.mark.parametrize("name,mtype,ftype", [("HEXA20", "hexahedron20", "quad8"),
                                               ("TETRA10", "tetra10", "triangle6")])
@pytest.mark.parametrize("fmt", ["med", "gmsh22", "vtu"])
def test_3d_files_keep_code_aster_order(tmp_path, name, mtype, ftype, fmt):
    """MED files hold code_aster's node order, Gmsh and VTU files VTK's (meshio's): both
    read back into the generator's cells, face groups included."""
    raw = box(2, 1, 2, cell=name)
    el = element(name)
    cells = raw.cells if fmt == "med" else raw.cells[:, el.reverse]
    top = raw.face_groups["top"]
    if fmt == "med":
        m = meshio.Mesh(raw.points, [(mtype, cells), (ftype, top)],
                        cell_data={"cell_tags": [np.full(len(cells), -1), np.full(len(top), -2)]})
        m.cell_tags = {-1: ["VOL"], -2: ["top"]}
        path = tmp_path / "m.med"
    elif fmt == "gmsh22":
        tags = [np.full(len(cells), 1), np.full(len(top), 2)]
        m = meshio.Mesh(raw.points, [(mtype, cells), (ftype, top)],
                        cell_data={"gmsh:physical": tags, "gmsh:geometrical": tags},
                        field_data={"VOL": [1, 3], "top": [2, 2]})
        path = tmp_path / "m.msh"
    else:
        m = meshio.Mesh(raw.points, [(mtype, cells), (ftype, top)],
                        cell_sets={"top": [np.zeros(0, int), np.arange(len(top))]})
        path = tmp_path / "m.vtu"
    meshio.write(path, m, **({"file_format": "gmsh22", "binary": False} if fmt == "gmsh22" else {}))
    back = read_mesh(path)
    assert back.cell_type == name and np.array_equal(back.cells, raw.cells)
    assert np.array_equal(back.face_groups["top"], top)


def test_unsupported_3d_cells_are_refused_on_one_line():
    pts = np.random.default_rng(0).random((27, 3))
    for cells, words in (
            ([("hexahedron27", np.arange(27)[None])], ["unsupported 3-D cells hexahedron27 x1",
                                                       "Mesh.SecondOrderIncomplete=1"]),
            ([("hexahedron", np.arange(8)[None])], ["unsupported 3-D cells hexahedron x1", "Gmsh -order 2"]),
            ([("wedge", np.arange(6)[None])], ["unsupported 3-D cells wedge x1", "HEXA20"]),
            ([("tetra10", np.arange(10)[None]), ("hexahedron20", np.arange(20)[None])],
             ["one cell type per mesh"]),
            ([("tetra10", np.arange(10)[None]), ("quad8", np.arange(8)[None])],
             ["unsupported faces quad8 x1", "triangle6"])):
        with pytest.raises(MeshError) as exc:
            from_meshio(meshio.Mesh(pts, cells), "solid")
        text = str(exc.value)
        assert "\n" not in text and all(w in text for w in words), text


# -- solutions through the whole set-up ------------------------------------------------------
def distorted(raw, amount, seed=0):
    """``raw`` with its interior vertices moved at random by up to ``amount`` (m) and its
    mid-edge nodes put back at the middle of their (straight) edges."""
    rng = np.random.default_rng(seed)
    x = raw.points.copy()
    lo, hi = x.min(axis=0), x.max(axis=0)
    inside = np.all((x > lo + 1e-9) & (x < hi - 1e-9), axis=1)
    vertex = np.zeros(len(x), bool)
    vertex[raw.vertex_nodes] = True
    move = inside & vertex
    x[move] += rng.uniform(-amount, amount, (int(move.sum()), 3))
    e = raw.cells[:, element(raw.cell_type).edges]
    x[e[..., 2]] = 0.5 * (x[e[..., 0]] + x[e[..., 1]])
    raw.points = x
    return raw.check()


def solve(tmp_path, text, raw=None):
    """Set up and solve the case ``text`` in-process (with the input mesh ``raw`` if
    given); returns the model."""
    from xfemcontact.model import Model

    case = load_case(write_case(tmp_path, text))
    model = Model.from_case(case, raw)
    assert model.solve() > 0
    return model


def box_case(cell, n, loads, params="", body=""):
    return f"""
        [parameters]
        {params}
        [mesh]
        box = {{nx = {n}, ny = {n}, nz = {n}, x = [0, 1], y = [0, 1.5], z = [0, 2], cell = "{cell}"}}
        [material]
        E = {E}
        nu = {NU}
        {body}
        {loads}
        """


EPS = np.array([[1.0, 0.4, -0.3], [0.4, -0.6, 0.2], [-0.3, 0.2, 0.8]]) * 1e-3    # strain of the patch tests
LINEAR = ("1e-3*(1.0*x + 0.4*y - 0.3*z) + 2e-4", "1e-3*(0.4*x - 0.6*y + 0.2*z) - 1e-4",
          "1e-3*(-0.3*x + 0.2*y + 0.8*z) + 3e-4")
FACES = ("left", "right", "front", "back", "bottom", "top")


def stress_of(eps):
    lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    return lam * np.trace(eps) * np.eye(3) + 2 * mu * eps


def stresses(model):
    """All quadrature-point stresses ``(k, 6)`` of the model (Voigt, code_aster's order)."""
    return np.concatenate([v.stress[v.w > 0] for v in model.stresses()])


def voigt(s):
    return np.array([s[0, 0], s[1, 1], s[2, 2], s[0, 1], s[0, 2], s[1, 2]])


def patch_meshes(cell):
    """The meshes of the patch tests: a distorted generated box, and for TETRA10 the
    unstructured Gmsh mesh too (None: the generated box of the case)."""
    out = [("distorted", lambda: distorted(box(3, 3, 3, x=(0, 1), y=(0, 1.5), z=(0, 2), cell=cell), 0.08))]
    if cell == "TETRA10":
        out.append(("gmsh", lambda: read_mesh(MESHES / "jittered_tetra10.msh")))
    return out


@pytest.mark.parametrize("cell", SOLIDS)
def test_patch_imposed_displacements(tmp_path, cell):
    """A linear displacement imposed on the whole boundary is reproduced at every node
    to round-off, with a constant stress, on distorted hexahedra, generated tetrahedra
    and the unstructured Gmsh tetrahedra."""
    loads = f"""
        [[dirichlet]]
        group = {list(FACES)}
        DX = "{LINEAR[0]}"
        DY = "{LINEAR[1]}"
        DZ = "{LINEAR[2]}"
        """
    for label, make in patch_meshes(cell):
        raw = make()
        model = solve(tmp_path, box_case(cell, 3, loads), raw)
        x, u = model.mesh.x, model.displacement()
        exact = x @ EPS.T + np.array([2e-4, -1e-4, 3e-4])
        assert np.abs(u - exact).max() < 1e-14, label
        assert np.abs(stresses(model) - voigt(stress_of(EPS))).max() < 1e-9 * E * 1e-3, label


def rigid_residual(x, u):
    """What is left of ``u (n, 3)`` at ``x (n, 3)`` after the best rigid motion, m."""
    rows = np.zeros((3 * len(x), 6))
    for c in range(3):
        rows[c::3, c] = 1.0
        for k, axis in enumerate(np.eye(3)):
            rows[c::3, 3 + k] = np.cross(axis, x)[:, c]
    coef, *_ = np.linalg.lstsq(rows, u.ravel(), rcond=None)
    return np.abs(rows @ coef - u.ravel()).max()


SUPPORTS = """
        [[dirichlet]]
        group = "P1"
        DX = 0
        DY = 0
        DZ = 0
        [[dirichlet]]
        group = "P2"
        DY = 0
        DZ = 0
        [[dirichlet]]
        group = "P4"
        DZ = 0
        """


@pytest.mark.parametrize("cell", SOLIDS)
def test_patch_tractions_and_pressure(tmp_path, cell):
    """Constant stresses from face tractions (t = sigma n on the six faces) and from a
    pressure on every face, the rigid motions held by three corners: the stress is
    reproduced to round-off, the displacement up to a rigid motion."""
    sigma = stress_of(EPS)
    axis_of = {"left": (0, -1), "right": (0, 1), "front": (1, -1), "back": (1, 1), "bottom": (2, -1), "top": (2, 1)}
    loads = SUPPORTS
    for face, (axis, sign) in axis_of.items():
        t = sign * sigma[:, axis]
        loads += f"""
        [[traction]]
        group = "{face}"
        FX = {t[0]!r}
        FY = {t[1]!r}
        FZ = {t[2]!r}
        """
    for label, make in patch_meshes(cell):
        if label == "gmsh":                   # the corners of the Gmsh file: no node groups
            continue
        model = solve(tmp_path, box_case(cell, 3, loads), make())
        assert np.abs(stresses(model) - voigt(sigma)).max() < 1e-10 * np.abs(sigma).max(), label
        x, u = model.mesh.x, model.displacement()
        assert rigid_residual(x, u - x @ EPS.T) < 1e-14, label
    p = 1.0e3
    pressure = SUPPORTS + f"""
        [[traction]]
        group = {list(FACES)}
        PRES = {p}
        """
    model = solve(tmp_path, box_case(cell, 2, pressure))
    assert np.abs(stresses(model) - voigt(-p * np.eye(3))).max() < 1e-10 * p
    x, u = model.mesh.x, model.displacement()
    assert rigid_residual(x, u + p * (1 - 2 * NU) / E * x) < 1e-15


QUADRATIC = ("2e-3*x*x + 1e-3*y*z", "-1e-3*x*z + 5e-4*y*y", "3e-3*x*y - 1e-3*z*z")


def quadratic_body_force():
    """-div sigma of :data:`QUADRATIC`: constant (N/m^3)."""
    lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    # grad div u and laplacian of u, by hand: div u = 4e-3 x + 1e-3 y - 2e-3 z
    grad_div = np.array([4e-3, 1e-3, -2e-3])
    lap = np.array([4e-3, 1e-3, -2e-3])
    return -(lam + mu) * grad_div - mu * lap


@pytest.mark.parametrize("cell", SOLIDS)
def test_quadratic_field_is_exact(tmp_path, cell):
    """A quadratic displacement with its (constant) body force, imposed on the boundary:
    P2 (TETRA10) and serendipity (HEXA20) cells hold every quadratic, so the nodal
    displacements are exact to round-off."""
    f = quadratic_body_force()
    loads = f"""
        [[dirichlet]]
        group = {list(FACES)}
        DX = "{QUADRATIC[0]}"
        DY = "{QUADRATIC[1]}"
        DZ = "{QUADRATIC[2]}"
        [body_force]
        FX = {f[0]!r}
        FY = {f[1]!r}
        FZ = {f[2]!r}
        """
    model = solve(tmp_path, box_case(cell, 2, loads))
    x, u = model.mesh.x, model.displacement()
    X, Y, Z = x.T
    exact = np.stack([2e-3 * X * X + 1e-3 * Y * Z, -1e-3 * X * Z + 5e-4 * Y * Y, 3e-3 * X * Y - 1e-3 * Z * Z], 1)
    assert np.abs(u - exact).max() < 1e-13


def manufactured():
    """A smooth displacement u = phi e, phi = sin(x) sin(y) sin(z), and its body force
    -div sigma = -(lam + mu) H e + 3 mu phi e, H the Hessian of phi: the formulas of u
    and f, and u as a function of points ``(..., 3)``."""
    lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    e = (1e-3, 5e-4, -7e-4)
    phi = "sin(x)*sin(y)*sin(z)"
    H = [[f"-{phi}", "cos(x)*cos(y)*sin(z)", "cos(x)*sin(y)*cos(z)"],
         ["cos(x)*cos(y)*sin(z)", f"-{phi}", "sin(x)*cos(y)*cos(z)"],
         ["cos(x)*sin(y)*cos(z)", "sin(x)*cos(y)*cos(z)", f"-{phi}"]]
    u = [f"{c!r}*{phi}" for c in e]
    f = [f"-{lam + mu!r}*(" + " + ".join(f"{e[j]!r}*({H[i][j]})" for j in range(3)) + f") + {3 * mu * e[i]!r}*{phi}"
         for i in range(3)]

    def exact(x):
        p = np.sin(x[..., 0]) * np.sin(x[..., 1]) * np.sin(x[..., 2])
        return p[..., None] * np.array(e)
    return u, f, exact


def l2_error(model, exact):
    """The L2 norm (m^2.5) of the displacement error, by a degree-6 rule on every cell."""
    mesh = model.mesh
    el = mesh.element
    q, w = el.quadrature(6)
    xc = mesh.x[mesh.cell_nodes]
    det = el.jacobian_dets(xc, q)
    pts = np.einsum("qa,kai->kqi", el.shape(q), xc)
    uh = np.einsum("qa,kai->kqi", el.shape(q), model.displacement()[mesh.cell_nodes])
    return math.sqrt(np.einsum("kq,q,kqi->", det, w, (uh - exact(pts)) ** 2))


@pytest.mark.parametrize("cell", SOLIDS)
def test_convergence_order(tmp_path, cell):
    """The L2 error of a smooth manufactured solution falls as h^3 (quadratic cells)."""
    u, f, exact = manufactured()
    loads = f"""
        [[dirichlet]]
        group = {list(FACES)}
        DX = "{u[0]}"
        DY = "{u[1]}"
        DZ = "{u[2]}"
        [body_force]
        FX = "{f[0]}"
        FY = "{f[1]}"
        FZ = "{f[2]}"
        """
    errors = [l2_error(solve(tmp_path, box_case(cell, n, loads)), exact) for n in (2, 4)]
    order = math.log2(errors[0] / errors[1])
    assert 2.7 < order < 3.5, (errors, order)


# -- the command line ----------------------------------------------------------------------
MPI_CASE = """
    title = "3-D box under body force, traction and pressure"
    [mesh]
    box = {nx = 3, ny = 2, nz = 4, x = [0, 1], y = [0, 1], z = [0, 2], cell = "CELL"}
    [material]
    E = 2e5
    nu = 0.3
    [[dirichlet]]
    group = "bottom"
    DX = 0
    DY = 0
    DZ = 0
    [[traction]]
    group = "right"
    FX = "1e2*z"
    FZ = -50
    [[traction]]
    group = "top"
    PRES = "1e2*(1 + x*y)"
    [body_force]
    FY = -3e2
    [[test]]
    field = "DZ"
    type = "MIN"
    reference = 0
    tolerance = 1
    criterion = "ABSOLU"
    """


@pytest.mark.mpi
@pytest.mark.parametrize("cell", SOLIDS)
def test_two_processes_give_the_one_process_answer(tmp_path, cell):
    import h5py

    path = write_case(tmp_path, MPI_CASE.replace("CELL", cell))
    runs = {}
    for np_ in (1, 2):
        out = tmp_path / f"np{np_}"
        done = run_cli(["run", path, "-o", out], np=np_ if np_ > 1 else None)
        assert done.returncode == 0, done.stderr
        runs[np_] = out
    assert len(results(runs[2])["partition"]["cells_per_process"]) == 2
    with h5py.File(runs[1] / "fields.h5") as a, h5py.File(runs[2] / "fields.h5") as b:
        assert list(a) == list(b)
        scale = np.abs(a["data2"][()]).max() + np.abs(a["data3"][()]).max() + np.abs(a["data4"][()]).max()
        for name in ("data0", "data1"):               # points and cells: the same numbering
            assert np.array_equal(a[name][()], b[name][()])
        for name in ("data2", "data3", "data4"):       # DX, DY, DZ
            assert np.abs(a[name][()] - b[name][()]).max() <= 1e-10 * scale


CANTILEVER = """\
title = "cantilever"
[mesh]
box = {nx = 4, ny = 4, nz = 4, x = [0, 1], y = [0, 1], z = [0, 2], cell = "TETRA10"}
[material]
E = 1.0e10
nu = 0.25
[[dirichlet]]
group = "left"
DX = 0
DY = 0
DZ = 0
[[dirichlet]]
group = "front"
DY = 0
[body_force]
FZ = -2.5e4
FX = 1e4
[output]
plots = false
"""


@pytest.mark.mpi
@pytest.mark.parametrize("np_", [2, 3])
def test_clamped_nodes_held_on_every_process(tmp_path, run_once, np_):
    """A process holding a node of a clamped face only through a cell that touches the
    face by an edge left its copy free: 2 more dofs on 2 processes and DZ 1.7e-3 off."""
    import h5py

    path = run_once.case(CANTILEVER)
    (p, one), many = run_once(path), tmp_path / "many"       # one process: shared by both parameters
    assert p.returncode == 0
    done = run_cli(["run", path, "-o", many], np=np_)
    assert done.returncode == 0, done.stderr
    assert results(one)["dofs"] == results(many)["dofs"]
    with h5py.File(one / "fields.h5") as a, h5py.File(many / "fields.h5") as b:
        scale = max(np.abs(a[name][()]).max() for name in ("data2", "data3", "data4"))
        for name in ("data2", "data3", "data4"):       # DX, DY, DZ
            assert np.abs(a[name][()] - b[name][()]).max() <= 1e-10 * scale


def test_level_set_missing_the_domain_runs_without_interface(tmp_path):
    """A level set that does not meet a 3-D mesh: a warning, and the case runs without an
    interface (cutting level sets: tests/test_contact3d.py, tests/test_gauss3d.py,
    tests/test_xfem3d_bulk.py)."""
    text = MPI_CASE.replace("CELL", "HEXA20") + '\n[interface]\nlevel_set = "z + 1"\n'
    done = run_cli(["run", write_case(tmp_path, text), "-o", tmp_path / "out2"])
    assert done.returncode == 0 and "does not meet the domain" in done.stderr, done.stderr


def test_readme_example_runs(tmp_path):
    """cases/box_hexa20.toml, the README's 3-D example: its test table is OK, and the
    output folder has fields.xdmf with HEXA20 cells, the 3-D deformed view (the body cut
    in half) and no interface plot (no interface)."""
    done = run_cli(["run", ROOT / "cases" / "box_hexa20.toml", "-o", tmp_path / "out"])
    assert done.returncode == 0, done.stdout + done.stderr
    r = results(tmp_path / "out")
    assert r["mesh"]["cell_type"] == "HEXA20" and all(t["ok"] for t in r["tests"])
    m = meshio.read(tmp_path / "out" / "fields.xdmf")
    assert m.cells[0].type == "hexahedron20" and "DZ" in m.point_data and "SIZZ" in m.cell_data
    assert (tmp_path / "out" / "plot_deformed.png").stat().st_size > 10_000
    assert not (tmp_path / "out" / "plot_interface.png").exists()


def test_3d_refusals_before_the_set_up(tmp_path):
    """Rigid-body motions left free, a 3-D mesh file with a plane model, tractions on a
    node group: one line each, exit code 2."""
    free = MPI_CASE.replace("CELL", "TETRA10").replace("DZ = 0\n", "")
    done = run_cli(["run", write_case(tmp_path, free, "free.toml"), "-o", tmp_path / "o1"])
    assert done.returncode == 2
    assert ("rigid-body motion not prevented: nothing imposes DZ (translation in z is free); "
            "2 rotations are free") in done.stderr, done.stderr
    plane = f"""
        [mesh]
        file = "{MESHES / 'jittered_tetra10.msh'}"
        [material]
        E = 1e5
        nu = 0.3
        [[dirichlet]]
        group = "bottom"
        DX = 0
        DY = 0
        """
    done = run_cli(["run", write_case(tmp_path, plane, "plane.toml"), "-o", tmp_path / "o2"])
    assert done.returncode == 2
    assert 'TETRA10 cells are 3-D but material.model = "C_PLAN" is 2-D (use model = "3D")' in done.stderr
    on_nodes = MPI_CASE.replace("CELL", "HEXA20").replace('group = "right"', 'group = "P2"')
    done = run_cli(["run", write_case(tmp_path, on_nodes, "nodes.toml"), "-o", tmp_path / "o3"])
    assert done.returncode == 2
    assert "'P2' is a node group of box; tractions (FORCE_FACE, PRES_REP) act on face groups" in done.stderr
    for d in (done,):
        assert len([line for line in d.stderr.splitlines() if line.strip()]) == 1
