"""Thin spherical caps just above a plane of vertices (issue 21; bench/contact3d_caps.py).

The sphere of radius R centred at (0.5, 0.5, 0.34 - R) in the unit box of 3 x 3 x 3 cells:
its top is 0.02 h above the vertex plane z = 1/3.  Under a uniform pressure (sigma = -p
I) LAGS_C = -p at every interface point.  Before: R = 2 m on HEXA20 crossed the face z =
1/3 of the middle cell without crossing its edges and the cell above was not cut (a hole
of 0.083 m^2 in the interface, 15 dofs open, LAGS_C 0.69 p off); R = 20 m had no full cell
(dofs up to -1.6e4 Pa, 6 to 10 dofs open).
"""
import importlib.util

import numpy as np
import pytest

from conftest import ROOT, write_case
from xfemcontact.case import load_case
from xfemcontact.model import Model

_spec = importlib.util.spec_from_file_location("contact3d_caps", ROOT / "bench" / "contact3d_caps.py")
caps = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(caps)
P = caps.P


def cap(cell, radius, top=0.34, n=3):
    """The case of bench/contact3d_caps.py (one text for the bench and the tests)."""
    return caps.case(cell, n, radius, top)


def cap_area(radius, top=0.34, n=1000):
    """Area of the cap over the unit square (midpoint rule on the projection)."""
    s = (np.arange(n) + 0.5) / n
    r2 = (s[:, None] - 0.5) ** 2 + (s[None, :] - 0.5) ** 2
    return float(np.mean(radius / np.sqrt(radius ** 2 - r2)))



@pytest.mark.parametrize("cell, radius, tol", [("HEXA20", 2.0, 2e-3), ("HEXA20", 20.0, 1e-4),
                                               ("TETRA10", 20.0, 3e-5), ("TETRA10", 2.0, 2e-3),
                                               ("TETRA10", 5.0, 1e-3)])
def test_thin_cap_over_a_vertex_plane(tmp_path, null_pivot_detection, cell, radius, tol):
    """The whole cap is followed (its area), every dof in contact, LAGS_C = -p to the
    discretisation (the same caps at z = 0.40: HEXA20 4.9e-4, 8.6e-7; TETRA10 6.1e-6,
    8.1e-4, 4.8e-5), no null pivot, every vertex value within 5 % of -p.  TETRA10 R = 2 and
    5 m lost 1.3e-3 and 3.5e-4 m^2 of area at the rim (LAGS_C 0.015 p and 0.0097 p off) while
    each cell placed the rim's mid-nodes in its own reference coordinates
    (cut3d.project_midpoints now takes the direction in physical space on faces)."""
    model = Model.from_case(load_case(write_case(tmp_path, cap(cell, radius))))
    assert model.solve() > 0
    v = model.interface_values()
    assert abs(v["w"].sum() - cap_area(radius)) < 1e-4
    assert np.abs(v["LAGS_C"] + P).max() <= tol * P
    pr = model.problem
    assert (pr.chi[pr.space.carriers_of >= 0] == 1).all()
    assert np.abs(pr.vertex_values(model.x)[0] + P).max() <= 0.05 * P
    assert model.solver_info()["mumps"]["null_pivots"] == 0
