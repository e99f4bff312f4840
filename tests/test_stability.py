"""A stable multiplier space (issue 4): no null pivot, no oscillation, as the arc moves
across the nodes.

The SSNV509 circle is shifted upwards by 50 steps across one cell height, so that
it passes through and very near the vertices and mid-nodes of the 20 x 20 QUAD8 and
800 TRIA6 meshes.  With MUMPS null-pivot detection on (ICNTL(24) = 1) every
factorisation reports INFOG(28) = 0, and LAGS_C along the interface does not
oscillate: its second divided difference from point to point (a discrete
d^2 LAGS_C / ds^2, the curvature an oscillation blows up like amplitude / h^2)
stays of the order of the exact one, max |d^2 sigma_nn / ds^2| = 0.2 / R^2.
"""
import copy
import dataclasses

import numpy as np
import pytest

from conftest import CASES, MESHES
from xfemcontact.case import load_case
from xfemcontact.case.formula import compile_formula
from xfemcontact.mesh.generate import rectangle
from xfemcontact.mesh.read import read_mesh
from xfemcontact.model import Model

N_POSITIONS = 50



def shifted(case, yc):
    itf = dataclasses.replace(case.interface,
                              level_set=compile_formula(f"(x-5)**2 + (y-{yc!r})**2 - 64.27"))
    return dataclasses.replace(case, interface=itf)


R = np.sqrt(64.27)
MERGE = 0.01          # m (h / 50): interface points closer than this are one place
EXACT_CURVATURE = 0.2 / R ** 2          # max |d^2 (-0.1 sin^2 t) / ds^2|, Pa/m^2


def interface_errors(model, yc):
    """Errors and second divided differences of LAGS_C along the arc, one value per point."""
    v = model.interface_values()
    t = np.arctan2(v["y"] - yc, v["x"] - 5.0)
    err_c = v["LAGS_C"] + 0.1 * np.sin(t) ** 2
    err_f = v["LAGS_F1"] - (v["x"] - 5.0) / (2.0 * (v["y"] - yc))
    _, first = np.unique(np.round(t, 12), return_index=True)     # each point once, by angle
    s, lam = _merge_close(R * t[first], v["LAGS_C"][first], MERGE)
    slope = np.diff(lam) / np.diff(s)
    curvature = 2.0 * np.diff(slope) / (s[2:] - s[:-2])
    return err_c[first], err_f[first], curvature


def _merge_close(s, values, gap):
    """Average runs of abscissae ``s`` (sorted) closer than ``gap``."""
    group = np.r_[0, np.cumsum(np.diff(s) > gap)]
    n = group[-1] + 1
    count = np.bincount(group, minlength=n)
    return (np.bincount(group, weights=s, minlength=n) / count,
            np.bincount(group, weights=values, minlength=n) / count)


@pytest.mark.slow
# QUAD8: the discrete curvature stays within twice the exact one (no oscillation).
# TRIA6 (P1 multipliers): where the arc runs a few hundredths of h below a row of
# vertices, LAGS_C wiggles locally (amplitude ~1e-4, discrete curvature up to
# ~0.25 Pa/m^2 on this coarse mesh): a KNOWN LIMITATION (README), guarded here
# against regression, not claimed as "no oscillation".
@pytest.mark.parametrize("cell, mesh, tol_c, tol_f, osc_factor", [
    ("QUAD8", lambda: rectangle(20, 20), 1e-5, 5e-5, 2.0),
    ("TRIA6", lambda: read_mesh(MESHES / "ssnv509b.mmed"), 2e-4, 2e-3, 100.0),
])
def test_arc_sweep(null_pivot_detection, cell, mesh, tol_c, tol_f, osc_factor):
    base = load_case(CASES / "ssnv509a.toml")
    raw = mesh()
    worst = {"err_c": 0.0, "err_f": 0.0, "osc": 0.0, "null": 0, "ties": 0}
    for i in range(N_POSITIONS):
        yc = 11.77 + 0.5 * i / N_POSITIONS
        model = Model(shifted(base, yc), raw=copy.deepcopy(raw))
        assert model.solve() > 0, f"no convergence at yc = {yc}"
        info = model.solver_info()["mumps"]
        err_c, err_f, curvature = interface_errors(model, yc)
        worst["err_c"] = max(worst["err_c"], np.abs(err_c).max())
        worst["err_f"] = max(worst["err_f"], np.abs(err_f).max())
        worst["osc"] = max(worst["osc"], np.abs(curvature).max())
        worst["null"] = max(worst["null"], info["null_pivots"])
        worst["ties"] = max(worst["ties"], model.problem.space.n_ties)
        assert info["null_pivots"] == 0, f"MUMPS null pivots at yc = {yc}"
    print(f"\n{cell}: {N_POSITIONS} positions, max error LAGS_C {worst['err_c']:.2e} "
          f"LAGS_F1 {worst['err_f']:.2e}, largest second divided difference of LAGS_C "
          f"{worst['osc']:.2e} Pa/m^2 (exact curvature at most {EXACT_CURVATURE:.2e}), "
          f"INFOG(28) max {worst['null']}, ties {worst['ties']}")
    assert worst["err_c"] < tol_c and worst["err_f"] < tol_f
    # no node-to-node oscillation: the discrete curvature stays of the order of the exact one
    assert worst["osc"] < osc_factor * EXACT_CURVATURE


@pytest.mark.parametrize("name, gradient_ties", [("ssnv509a", 1), ("ssnv509b", 0)])
def test_multiplier_space_reproduces_linear_fields(name, gradient_ties):
    """Weak-vertex extrapolation and gradient ties keep every affine multiplier field:
    the vertex values rebuilt from the carriers (T) equal the field at every vertex of
    every cut cell.  SSNV509 a has one weak packet at the bottom of the arc, tied by
    gradient (its vertices keep the field's variation, which a merge would flatten)."""
    model = Model(load_case(CASES / f"{name}.toml"))
    space, mesh = model.problem.space, model.mesh
    xg = dict(zip(mesh.node_ids.tolist(), mesh.x.tolist()))
    # every vertex of a cut cell carries a dof, unless weak or eliminated by a gradient tie
    assert len(space.ids) == len(np.unique(space.topo.verts)) - space.n_weak - gradient_ties
    assert space.n_ties == gradient_ties
    co = space.carriers_of
    dof = space.representative(np.where(co >= 0, co, space.ids[0]))     # the dof each slot reads
    xc = np.array([[xg[g] for g in row] for row in dof])
    for f in (lambda x: 1.0 + 0 * x[..., 0], lambda x: x[..., 0], lambda x: 2.0 * x[..., 1] - x[..., 0]):
        vals = np.where(co >= 0, f(xc), 0.0)
        rebuilt = np.einsum("kvm,km->kv", space.T, vals)
        assert np.allclose(rebuilt, f(space.topo.xv), atol=1e-12)


@pytest.mark.parametrize("name", ["ssnv509a", "ssnv509a_med"])
def test_weak_vertices_continue_the_root_field(name):
    """A weak vertex takes the value of its root cell's own Q1 field: on these
    rectangular QUAD8 meshes the bilinear field x y (which every cell reproduces)
    comes back exactly at every weak vertex.  An affine fit of the root's four
    values would miss it by ~h^2 (and cost the arc ends of SSNV509 a half their
    LAGS_F1 accuracy)."""
    model = Model(load_case(CASES / f"{name}.toml"))
    space, mesh = model.problem.space, model.mesh
    assert space.n_weak > 0
    xg = dict(zip(mesh.node_ids.tolist(), mesh.x.tolist()))
    co = space.carriers_of
    dof = space.representative(np.where(co >= 0, co, space.ids[0]))
    xc = np.array([[xg[g] for g in row] for row in dof])
    vals = np.where(co >= 0, xc[..., 0] * xc[..., 1], 0.0)
    rebuilt = np.einsum("kvm,km->kv", space.T, vals)
    weak = ~np.isin(space.topo.verts, space.ids)
    exact = space.topo.xv[..., 0] * space.topo.xv[..., 1]
    assert weak.any()
    assert np.allclose(rebuilt[weak], exact[weak], atol=1e-11)


@pytest.mark.parametrize("theta", [0, 10, 20, 30, 45, 60, 75, 90, 120, 150])
def test_straight_interfaces_leave_no_kernel(theta):
    """A straight interface at any angle across unstructured (Gmsh) QUAD8 cells: the
    trace of every multiplier combination is non-zero (no kernel left by the ties).
    Gradient ties keep linear fields, and on a straight stretch the interpolant of the
    signed distance is a linear field with a zero trace: at 60 degrees a gradient tie
    brought it back (LAGS_C +-8000 Pa for -100 in a sticking solve)."""
    from xfemcontact.contact import space as cspace

    case = load_case(CASES / "campaign" / "line_stick-D_q8s_a+10_gen_nu3d.toml")
    t = np.radians(theta)
    itf = dataclasses.replace(case.interface, level_set=compile_formula(
        f"{np.cos(t)!r}*(y - 1.0) - {np.sin(t)!r}*(x - 1.0)"))
    mesh = dataclasses.replace(case.mesh, file=MESHES / "gmsh_quad8_2x2.msh")
    model = Model(dataclasses.replace(case, interface=itf, mesh=mesh))
    problem = model.problem
    space = problem.space
    assert cspace._kernel_carriers(space, model.mesh, problem._lin, problem.points.w) == set()

