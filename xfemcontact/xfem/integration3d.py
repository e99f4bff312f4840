"""Quadrature on the curved sub-tetrahedra and interface facets of cut 3-D cells.

A sub-tetrahedron is the TETRA10 map ``zeta -> xi`` of its nodes in the parent's
reference coordinates (:mod:`xfemcontact.xfem.cut3d`), composed with the parent's
isoparametric map ``xi -> x``; a point's weight is the rule's weight times both
Jacobian determinants (m^3).  Facets are TRIA6 maps ``eta -> xi`` composed the
same way: the physical tangents are ``J_parent dxi/deta``, their cross product is
the unit normal times the area element (m^2); the facets' node order makes it
point from the - side (LN < 0) to the + side (LN > 0), the 2-D convention.

Degrees: a sub-tetrahedron of a planar cut of an affine parent is straight, so a
rule of degree p integrates every polynomial of degree p in x exactly on it;
``SUBTET_DEGREE`` is the degree of an affine parent's stiffness integrand
(TETRA10: 2, HEXA20 parallelepipeds: 6 = 2 x 3), which also covers the cubic
Jacobian of a curved TETRA10 sub-cell.  Padding sub-cells and facets get zero
weights (and a point inside the parent).
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from xfemcontact.fem.elements import Element, determinants, inverses
from xfemcontact.fem.quadrature import gauss_tetrahedron, gauss_triangle
from xfemcontact.xfem.cut3d import TETRA10, TRIA6, Facets, SubTets, subtet_jacobians
from xfemcontact.xfem.integration import CellPoints, _parent_maps
from xfemcontact.xfem.tet_tables import TETRA10_EDGES

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]

#: polynomial degree of the rule on each sub-tetrahedron (see the module documentation)
SUBTET_DEGREE = {"TETRA10": 4, "HEXA20": 6}
#: the same on the cells with a curved sub-tetrahedron (:func:`curved_cells`): the degree
#: of grad N_a composed with the quadratic sub-cell map, times its cubic Jacobian
#: (HEXA20: 3 x 2 + 3 = 9, TETRA10: 1 x 2 + 3 = 5), so that a constant stress gives the
#: exact nodal forces (the patch test) on affine parents.  Degree 6 on a sphere-cut
#: HEXA20 box left the linear field 1.5e-9 off (relative), degree 9 1e-14; the rules have
#: 125 and 27 points (TETRA10: the same rule as degree 4)
CURVED_SUBTET_DEGREE = {"TETRA10": 5, "HEXA20": 9}
#: a sub-tetrahedron is curved when a mid-node is this far (in xi) from its edge's midpoint
CURVED = 1e-12


def rule_size(degree: int) -> int:
    """Points of the tetrahedron rule exact to ``degree`` (per sub-tetrahedron)."""
    return len(gauss_tetrahedron(degree)[1])


def subtet_points(el: Element, xc: FloatArray, sub: SubTets, degree: int | None = None) -> CellPoints:
    """Quadrature of the sub-tetrahedra ``sub`` of cells with coordinates ``xc (k, nn, 3)``:
    :class:`~xfemcontact.xfem.integration.CellPoints` with ``nq = ns x`` (rule size),
    weights in m^3, the parent's shape functions and physical gradients at every point."""
    zeta, wz = gauss_tetrahedron(SUBTET_DEGREE[el.name] if degree is None else degree)
    k, ns = sub.side.shape
    nq = len(wz)
    live = np.repeat(sub.side != 0, nq, axis=1)                                  # (k, ns nq)
    xi = np.einsum("qa,ksai->ksqi", TETRA10.shape(zeta), sub.nodes).reshape(k, ns * nq, 3)
    xi[~live] = el.ref_nodes[: el.nv].mean(axis=0)
    det_sub = subtet_jacobians(sub.nodes, zeta).reshape(k, ns * nq)
    N, x, dNdx, det = _parent_maps(el, xc, xi)
    w = np.tile(wz, ns)[None, :] * det_sub * det * live
    return CellPoints(sub.cells, xi, x, w, np.repeat(sub.side, nq, axis=1), dNdx, N)


def curved_cells(sub: SubTets) -> BoolArray:
    """Cells ``(k,)`` with a live sub-tetrahedron whose mid-nodes are not all at the
    midpoints of their edges (to :data:`CURVED`): those of a curved interface, or of a
    planar one through a curved parent's reference cell."""
    v = sub.nodes[:, :, :4]
    mid = 0.5 * (v[:, :, TETRA10_EDGES[:, 0]] + v[:, :, TETRA10_EDGES[:, 1]])     # (k, ns, 6, 3)
    off = np.abs(sub.nodes[:, :, 4:] - mid).max(axis=(2, 3)) > CURVED
    return (off & (sub.side != 0)).any(axis=1)


def subtet_weights(el: Element, xc: FloatArray, sub: SubTets, degree: int = 3) -> tuple[FloatArray, IntArray]:
    """Weights (m^3) and sides, each ``(k, ns x rule size)``, of the sub-tetrahedra ``sub``
    without the shape functions: what volumes need.  The default degree 3 integrates a
    curved sub-tetrahedron's volume exactly on an affine parent (its Jacobian is cubic)."""
    zeta, wz = gauss_tetrahedron(degree)
    k, ns = sub.side.shape
    nq = len(wz)
    xi = np.einsum("qa,ksai->ksqi", TETRA10.shape(zeta), sub.nodes).reshape(k, ns * nq, 3)
    J = np.einsum("kai,kpaj->kpij", xc, el.dshape(xi))
    det = determinants(J) * subtet_jacobians(sub.nodes, zeta).reshape(k, ns * nq)
    side = np.repeat(sub.side, nq, axis=1)
    return np.tile(wz, ns)[None, :] * det * (side != 0), side


@dataclass
class FacetPoints:
    """Gauss points of the interface facets of cut cells, padded to ``nf x`` (rule size)."""

    cells: IntArray      # (k,) local cell indices
    xi: FloatArray       # (k, np, 3) parent reference coordinates
    x: FloatArray        # (k, np, 3) physical points, m
    w: FloatArray        # (k, np) area weights, m^2 (0 on padding)
    normal: FloatArray   # (k, np, 3) unit normal from - to + (0 on padding)

    def take(self, rows: IntArray) -> FacetPoints:
        """The points of the cells at positions ``rows``."""
        return FacetPoints(*(getattr(self, f.name)[rows] for f in fields(self)))


def facet_points(el: Element, xc: FloatArray, phi_cell: FloatArray, fac: Facets, degree: int = 4) -> FacetPoints:
    """Gauss points (a triangle rule exact to ``degree``) on the facets ``fac`` of cells
    with coordinates ``xc (k, nn, 3)`` and LN node values ``phi_cell (k, nn)``."""
    eta, we = gauss_triangle(degree)
    k, nf = fac.live.shape
    nq = len(we)
    xi = np.einsum("qa,kfai->kfqi", TRIA6.shape(eta), fac.nodes)                # (k, nf, nq, 3)
    T = np.einsum("qaj,kfai->kfqij", TRIA6.dshape(eta), fac.nodes)              # dxi/deta (.., 3, 2)
    live = np.repeat(fac.live, nq, axis=1)
    xi = xi.reshape(k, nf * nq, 3)
    xi[~live] = el.ref_nodes[: el.nv].mean(axis=0)
    dN = el.dshape(xi)                                                           # (k, p, nn, 3)
    x = np.einsum("kpa,kai->kpi", el.shape(xi), xc)
    J = np.einsum("kai,kpaj->kpij", xc, dN)                                      # dx/dxi
    t = J @ T.reshape(k, nf * nq, 3, 2)                                          # physical tangents
    area = np.cross(t[..., 0], t[..., 1])                                        # n_h dA_h / d(eta)
    n = _unit_gradients(dN, J, phi_cell)
    w = np.tile(we, nf)[None, :] * np.einsum("kpi,kpi->kp", area, n) * live
    return FacetPoints(fac.cells, xi, x, w, n * live[..., None])


def level_set_normals(el: Element, xc: FloatArray, phi_cell: FloatArray, xi: FloatArray) -> FloatArray:
    """The unit normals ``n = grad LN / |grad LN|`` ``(k, p, 3)`` (from the - side to the +
    side; 0 where the gradient vanishes) at parent reference points ``xi (k, p, 3)`` of
    cells with coordinates ``xc (k, nn, 3)`` (m) and LN node values ``phi_cell (k, nn)``:
    the normals of :func:`facet_points`, at any points (the facets' nodes)."""
    dN = el.dshape(xi)
    return _unit_gradients(dN, np.einsum("kai,kpaj->kpij", xc, dN), phi_cell)


def _unit_gradients(dN: FloatArray, J: FloatArray, phi_cell: FloatArray) -> FloatArray:
    """grad LN / |grad LN| ``(k, p, 3)`` from the reference gradients ``dN (k, p, nn, 3)``
    and the Jacobians ``J (k, p, 3, 3)`` (dx/dxi); 0 where the gradient vanishes."""
    g = np.einsum("kpaj,kpji,ka->kpi", dN, inverses(J)[1], phi_cell)            # physical grad LN
    gn = np.linalg.norm(g, axis=-1, keepdims=True)
    return np.where(gn > 0, g / np.where(gn > 0, gn, 1.0), 0.0)


#: a sub-tetrahedron face lies on a face of its parent when its nodes are this close
#: to the face's plane in reference coordinates (the cutting keeps them on it exactly,
#: up to round-off)
ON_FACE = 1e-10


def cut_face_points(el: Element, xc: FloatArray, sub: SubTets, local_face: IntArray,
                    degree: int = 5) -> tuple[FacetPoints, IntArray]:
    """Gauss points on the face ``local_face (k,)`` of cut cells ``xc (k, nn, 3)`` with
    sub-tetrahedra ``sub`` (one row per face: a cell with two loaded faces comes twice),
    integrated on each side separately.

    The sub-tetrahedra tile the parent, so their faces lying in the plane of the
    parent face (in reference coordinates, to :data:`ON_FACE`) tile that face, each
    on the side of its sub-tetrahedron.  Each such TRIA6 face is mapped like an
    interface facet (``eta -> xi -> x``, a triangle rule exact to ``degree``).
    The weights are signed: a face of a sub-tetrahedron is oriented outward of it (the
    right-hand rule of :attr:`TETRA10.faces`), and a sub-tetrahedron lies inside its
    parent, so on the parent's face that is the parent's outward normal; where a thin
    curved sub-tetrahedron folds, its face folds too and the fold counts negative, as
    in the volume integrals (:func:`~xfemcontact.xfem.cut3d.negative_sides`).  With
    absolute weights the faces of a sphere-cut HEXA20 face summed 2.5e-5 m^2 too much.
    Returns the points (weights in m^2, ``normal`` the parent's outward unit normal,
    zero weight on padding and on the faces of sub-tetrahedra off the face) and their
    sides ``(k, p)`` (-1 / +1, 0 on padding).
    """
    k, ns = sub.side.shape
    ref = el.ref_nodes[el.faces[local_face, :3]]                                   # (k, 3, 3)
    n_ref = np.cross(ref[:, 1] - ref[:, 0], ref[:, 2] - ref[:, 0])                 # outward in xi
    n_ref /= np.linalg.norm(n_ref, axis=1, keepdims=True)
    F = sub.nodes[:, :, TETRA10.faces]                                             # (k, ns, 4, 6, 3)
    dist = np.einsum("ksfai,ki->ksfa", F - ref[:, None, None, :1], n_ref)
    on = (np.abs(dist) <= ON_FACE).all(axis=-1) & (sub.side != 0)[..., None]      # (k, ns, 4)
    F = F.reshape(k, ns * 4, 6, 3)
    on = on.reshape(k, ns * 4)
    side = np.repeat(sub.side, 4, axis=1)
    eta, we = gauss_triangle(degree)
    nq = len(we)
    xi = np.einsum("qa,kfai->kfqi", TRIA6.shape(eta), F).reshape(k, -1, 3)
    T = np.einsum("qaj,kfai->kfqij", TRIA6.dshape(eta), F).reshape(k, -1, 3, 2)   # dxi/deta
    live = np.repeat(on, nq, axis=1)
    xi[~live] = el.ref_nodes[: el.nv].mean(axis=0)
    J = np.einsum("kai,kpaj->kpij", xc, el.dshape(xi))
    t = J @ T
    m = np.einsum("kpji,kj->kpi", inverses(J)[1], n_ref)                           # J^-T n_ref: outward
    n = m / np.linalg.norm(m, axis=-1, keepdims=True)
    area = np.einsum("kpi,kpi->kp", np.cross(t[..., 0], t[..., 1]), n)           # signed, m^2 per d(eta)
    x = np.einsum("kpa,kai->kpi", el.shape(xi), xc)
    w = np.tile(we, ns * 4)[None, :] * area * live
    pts = FacetPoints(sub.cells, xi, x, w, n * live[..., None])
    return pts, np.repeat(side, nq, axis=1) * live


def concat(parts: list[FacetPoints]) -> FacetPoints:
    """One :class:`FacetPoints` of the rows of ``parts`` (cut cells, then the cells
    owning interface faces: :meth:`~xfemcontact.xfem.geometry.Geometry.interface_points`),
    padded to the largest number of points with zero weights and normals (padding
    points repeat the row's first point, inside its cell)."""
    npts = max((p.w.shape[1] for p in parts), default=1)

    def pad(a: FloatArray, fill_first: bool) -> FloatArray:
        extra = npts - a.shape[1]
        if extra == 0:
            return a
        rep = np.repeat(a[:, :1], extra, axis=1) if fill_first else np.zeros((len(a), extra) + a.shape[2:])
        return np.concatenate([a, rep], axis=1)

    if not parts:
        return FacetPoints(np.zeros(0, np.int64), np.zeros((0, 1, 3)), np.zeros((0, 1, 3)), np.zeros((0, 1)),
                           np.zeros((0, 1, 3)))
    return FacetPoints(np.concatenate([p.cells for p in parts]),
                       np.concatenate([pad(p.xi, True) for p in parts]),
                       np.concatenate([pad(p.x, True) for p in parts]),
                       np.concatenate([pad(p.w, False) for p in parts]),
                       np.concatenate([pad(p.normal, False) for p in parts]))


#: a point's tangent t1 comes from the interface's axis unless the normal is within this
#: (the sine of the angle) of it; then from the next axis (a cap of about 6 degrees)
POLE = 0.1


def interface_axis(n: FloatArray, weights: FloatArray, comm: Any = None) -> int:
    """The coordinate axis (0, 1, 2) least aligned with the interface: the smallest
    largest |n_i| over the points of non-zero weight (of every process when ``comm``,
    an mpi4py communicator, is given), the first of equals to 1e-12."""
    live = weights != 0
    big = np.abs(n[live]).max(axis=0, initial=0.0) if live.any() else np.zeros(3)
    if comm is not None:
        from mpi4py import MPI

        big = np.array(big, dtype=float)
        comm.Allreduce(MPI.IN_PLACE, big, op=MPI.MAX)
    return int(np.argmin(np.asarray(big) + 1e-12 * np.arange(3)))


def tangent_basis(n: FloatArray, axis: int = 0) -> FloatArray:
    """The tangent basis ``(..., 3, 2)`` (columns t1, t2) of unit normals ``n (..., 3)``:
    t1 the unit projection of the coordinate axis ``axis`` (:func:`interface_axis`) on
    the tangent plane, t2 = n x t1, so that (t1, t2, n) is right-handed.  Where the
    normal is within :data:`POLE` of the axis, the next axis (``axis + 1`` mod 3) is
    projected instead.  Deterministic, constant on a plane, continuous on a curved
    surface except across the edge of those caps (no tangent field of a sphere is
    continuous everywhere).  Zero where n is zero (padding)."""
    def projected(ax: int) -> tuple[FloatArray, FloatArray]:
        e = np.zeros(3)
        e[ax] = 1.0
        t = e - n[..., ax:ax + 1] * n
        return t, np.linalg.norm(t, axis=-1, keepdims=True)

    t1, nt = projected(axis)
    t1b, ntb = projected((axis + 1) % 3)
    pole = nt < POLE
    t1, nt = np.where(pole, t1b, t1), np.where(pole, ntb, nt)
    live = np.linalg.norm(n, axis=-1, keepdims=True) > 0
    t1 = np.where(live & (nt > 0), t1 / np.where(nt > 0, nt, 1.0), 0.0)
    t2 = np.cross(n, t1)
    return np.stack([t1, t2], axis=-1)
