"""External loads and imposed displacements.

* Imposed displacements (code_aster DDL_IMPO / AFFE_CHAR_MECA_F): values of DX,
  DY (DZ) at the nodes of groups, numbers or formulas of (x, y (, z)).
* Surface tractions on edges in 2-D (FORCE_CONTOUR, N/m per unit length and unit
  thickness), on faces in 3-D (FORCE_FACE, Pa), or PRES_REP pressure in Pa,
  positive pushing into the body.  Faces are integrated with their own element
  (QUAD8, TRIA6) and a surface Jacobian.
* Body forces (FORCE_INTERNE, N/m^3).

Loads are integrated into local work arrays (``layout.local_array()``) with the
same component-blocked element dofs as the bulk.  Edges cut by the interface are
integrated on each side (their Heaviside dofs get the other side's share): the
caller passes the interface's edge splitter for that.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Iterable

import numpy as np

from xfemcontact.fem.coordinates import coordinates
from xfemcontact.fem.elements import Seg3, element, surface_geometry
from xfemcontact.fem.quadrature import gauss_segment

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.case.load import BodyForce, Dirichlet, Traction
    from xfemcontact.mesh.plex import LocalMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]


def imposed_values(mesh: LocalMesh, case_dirichlet: Iterable[Dirichlet],
                   group_nodes: Callable[[str], IntArray]) -> tuple[BoolArray, FloatArray]:
    """Imposed components at local nodes.

    Returns ``(fixed (n, 2) bool, values (n, 2))`` for DX, DY; later conditions
    override earlier ones on the same node and component.
    """
    n = len(mesh.x)
    fixed = np.zeros((n, 2), dtype=bool)
    values = np.zeros((n, 2))
    for bc in case_dirichlet:
        nodes = np.unique(np.concatenate([group_nodes(g) for g in bc.groups]))
        for c, comp in enumerate(("DX", "DY")):
            if comp in bc.components:
                fixed[nodes, c] = True
                values[nodes, c] = bc.components[comp](x=mesh.x[nodes, 0], y=mesh.x[nodes, 1])
    return fixed, values


def edge_geometry(xe: FloatArray, s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Points ``(k, nq, 2)``, length elements ``(k, nq)`` and outward unit normals
    ``(k, nq, 2)`` of SEG3 edges ``xe (k, 3, 2)`` oriented with their cell
    (counter-clockwise), at reference abscissae ``s (nq,)``."""
    N, dN = Seg3.shape(s), Seg3.dshape(s)
    pts = np.einsum("qa,kai->kqi", N, xe)
    tan = np.einsum("qa,kai->kqi", dN, xe)
    ds = np.linalg.norm(tan, axis=-1)
    normal = np.stack([tan[..., 1], -tan[..., 0]], axis=-1) / ds[..., None]
    return pts, ds, normal


def traction_vectors(spec: Traction, pts: FloatArray, normal: FloatArray) -> FloatArray:
    """Traction ``(k, nq, d)`` (N/m in 2-D, Pa in 3-D) of a traction spec at points
    ``pts (k, nq, d)`` with outward unit normals ``normal``."""
    xyz = coordinates(pts)
    if spec.pressure is not None:
        return -spec.pressure(**xyz)[..., None] * normal
    force = spec.force
    assert force is not None                 # a traction gives a force or a pressure
    return np.stack([force[name](**xyz) for name in ("FX", "FY", "FZ")[:pts.shape[-1]]], axis=-1)


def face_forces(xf: FloatArray, face_type: str, spec: Traction, degree: int = 5) -> FloatArray:
    """Nodal forces ``(k, 3, nf)`` (component, face node) of a traction on the faces
    ``xf (k, nf, 3)`` of 3-D cells (outward, element ``face_type``), integrated with
    a rule exact to ``degree`` on the face's reference element."""
    el = element(face_type)
    q, wq = el.quadrature(degree)
    pts, da, normal = surface_geometry(el, xf, q)
    t = traction_vectors(spec, pts, normal)
    return np.einsum("kq,kqi,qa->kia", wq[None] * da, t, el.shape(q))


def edge_forces(xe: FloatArray, spec: Traction,
                s_range: tuple[float | FloatArray, float | FloatArray] = (-1.0, 1.0), nq: int = 4) -> FloatArray:
    """Nodal forces ``(k, 2, 3)`` (component, edge node) of a traction on edges
    ``xe (k, 3, 2)``, integrated over the reference part ``s_range`` of each edge
    (arrays allowed, for edges split by the interface)."""
    q, wq = gauss_segment(nq)
    a, b = (np.broadcast_to(np.asarray(v, float), (len(xe),)) for v in s_range)
    half = 0.5 * (b - a)
    s = 0.5 * (a + b)[:, None] + half[:, None] * q[None, :, 0]          # (k, nq)
    N = Seg3.shape(s)                                                    # (k, nq, 3)
    dN = Seg3.dshape(s)
    pts = np.einsum("kqa,kai->kqi", N, xe)
    tan = np.einsum("kqa,kai->kqi", dN, xe)
    ds = np.linalg.norm(tan, axis=-1)
    normal = np.stack([tan[..., 1], -tan[..., 0]], axis=-1) / ds[..., None]
    t = traction_vectors(spec, pts, normal)
    w = wq[None] * half[:, None] * ds
    return np.einsum("kq,kqi,kqa->kia", w, t, N)


def body_forces(G_values: FloatArray, w: FloatArray, pts: FloatArray, body: BodyForce) -> FloatArray:
    """Nodal forces ``(ne, d, nf)`` of body force ``body`` at points ``pts (ne, nq, d)``
    for functions with values ``G_values (ne, nq, nf)`` and weights ``w (ne, nq)``."""
    xyz = coordinates(pts)
    b = np.stack([f(**xyz) for f in body.components], axis=-1)
    return np.einsum("eq,eqi,eqf->eif", w, b, G_values)
