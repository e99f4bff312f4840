"""The normal level set LN: nodal values, readjustment near nodes, cell classification.

LN is given at every node, mid-edge nodes included, and interpolated with the
cell's own shape functions (P2 on TRIA6, serendipity on QUAD8), so the
interface is the curved zero line of a quadratic field.  LN < 0 is the "-"
side (code_aster's slave side), LN > 0 the "+" side; n = grad LN / |grad LN|
points from - to +.

Readjustment rules (applied once, before anything is cut; the counts are
reported, like code_aster's XFEM_37/XFEM_63 messages):

1. *Round-off.*  |LN_i| <= 1e-12 * (largest |LN| of the nodes of the cells
   holding node i) is set to 0.
2. *Fit to vertex.*  A vertex is *near* when the zero of LN on one of its edges
   (root of the edge's quadratic interpolant) lies within 1e-6 of the edge's
   length from it.  Where the interface runs along an edge (both its vertices
   near, or one near and the other already 0), the near vertices get LN = 0: the
   interface then goes through them.  An edge whose two vertices are then 0 and
   whose mid-node value is below the same relative tolerance lies on the
   interface (its mid-node gets 0 too).  This moves the interface by at most
   about 1e-6 h and removes the strips thinner than that along an edge, whose
   Heaviside functions would make the matrix singular (their support falls like
   d / h: Jacobi-scaled condition numbers grow like (h / d)^2, 2.3e13 at 2e-6 h,
   tests/test_xfem_bulk.py).  A vertex the interface only passes near (a corner
   clipped off its cells, whose support falls like (d / h)^2 to (d / h)^4 and is
   dropped by the conditioning rule, :data:`xfemcontact.xfem.geometry.DROP_RATIO`)
   is fitted only within 1e-9 of an edge's length (``FIT_LONE_VERTEX``): fitting
   it kinks the interface by the distance moved, and a kinked straight interface
   that slides is no longer straight (measured on the sliding campaign's case
   ``limit-D_q8s_a-10_vfit``, a line 1e-7 h from a QUAD8 vertex: LAGS_C off by
   1.4e-5 relative when fitted, 2.2e-11 when not).
3. *One crossing per edge.*  If the quadratic on an edge changes sign twice (or
   vanishes at a vertex and changes sign inside, or touches zero inside), its
   mid-node value is moved to the nearest value for which the quadratic keeps
   one sign on the edge: the quadratic then touches zero at one point of the
   edge (the interface is tangent to it there) and the thin part of the other
   side cut off by the edge is dropped.  Where the sub-cells of a cut cell
   cannot follow the interface along such an edge (a tangency that is not at a
   node), or along an edge the interface nearly touches, the mid-node values of
   that cell's edges that sag towards zero are moved further, until the zero
   line leaves the edge (``push_off``; the cells are then cut again).  The
   number of such edges and the largest change of a mid-node value are
   reported.  In 3-D (``lift_double_crossings=False``) an edge whose two crossings are
   farther apart than 2e-6 of its length keeps its values: the cutting follows both
   (:func:`xfemcontact.xfem.cut3d.split_double_crossings`); only the tangencies (two
   crossings closer than that, or one at a vertex) are lifted.

Classification of a cell, from its node values after readjustment:
``cut`` (strictly positive and strictly negative node values), otherwise on the
side of its non-zero values (``+1`` or ``-1``); a cell whose nodes are all zero
is an error.  A cell with nodes of one sign but the other sign inside it (a
closed interface smaller than the cell) is an error asking for a finer mesh.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from xfemcontact.errors import GeometryError
from xfemcontact.fem.coordinates import coordinates
from xfemcontact.fem.elements import Seg3
from xfemcontact.mesh.plex import reduce_nodes

if TYPE_CHECKING:
    from mpi4py import MPI
    from numpy.typing import ArrayLike, NDArray

    from xfemcontact.mesh.plex import LocalMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]

ROUNDOFF = 1e-12
FIT_TO_VERTEX = 1e-6
#: a vertex the interface passes this near (relative to an edge's length) without running
#: along an edge from it is fitted too (rule 2)
FIT_LONE_VERTEX = 1e-9
VERTEX_ROOT = 1e-10       # reference-abscissa distance at which an edge root is its vertex


def nodal_values(mesh: LocalMesh, interface: Any, node_field: ArrayLike | None = None) -> FloatArray:
    """LN at every local node, scaled by a power of two (:func:`normalised`).

    ``interface``: the case's :class:`~xfemcontact.case.load.Interface` (not imported
    here: the case package imports the contact laws, which use this room);
    ``node_field (n,)``: LN at the local nodes when it has no level-set formula."""
    if interface.level_set is not None:
        phi = interface.level_set(**coordinates(mesh.x))
    else:
        phi = np.asarray(node_field, dtype=float)
    return normalised(phi, mesh.comm.tompi4py() if mesh.comm.size > 1 else None)


def normalised(phi: ArrayLike, comm: MPI.Comm | None = None) -> FloatArray:
    """``phi`` times the power of two that brings its largest magnitude (over all
    processes of the mpi4py ``comm``) into [0.5, 1).  Exact: the zero line and every
    decision of the readjustment (all relative) are unchanged, but a level set of
    magnitude 1e-300 or 1e300 no longer underflows or overflows in the edge roots."""
    phi = np.asarray(phi, dtype=float)
    finite = np.abs(phi[np.isfinite(phi)])
    top = float(finite.max()) if len(finite) else 0.0
    if comm is not None:
        from mpi4py import MPI

        top = comm.allreduce(top, op=MPI.MAX)
    if not top > 0 or not np.isfinite(top):
        return phi
    return np.ldexp(phi, -np.frexp(top)[1])


def edge_roots(phi_a: FloatArray, phi_b: FloatArray, phi_m: FloatArray) -> FloatArray:
    """Roots in the open interval (-1, 1) of the SEG3 quadratic through
    (-1, phi_a), (1, phi_b), (0, phi_m).  Returns ``(k, 2)``: the roots inside,
    sorted, first; NaN after them (none, or one root inside).

    The quadratic of an edge crossed once has its other root outside, on the
    left (below -1) or on the right depending on the edge's orientation and
    curvature; a straight LN has it at about -B / A, 1e12 away on either side,
    when the mid-node is off the edge's middle by round-off (as Gmsh places
    them).  The outside root is dropped and the inside one is always in the
    first column."""
    roots = quadratic_roots(phi_a, phi_b, phi_m)
    # roots within round-off of a vertex are the vertex, not a crossing inside
    roots[~((roots > -1.0 + VERTEX_ROOT) & (roots < 1.0 - VERTEX_ROOT))] = np.nan
    return np.sort(roots, axis=1)                 # NaN sorts last


def quadratic_roots(phi_a: FloatArray, phi_b: FloatArray, phi_m: FloatArray) -> FloatArray:
    """The real roots ``(k, 2)`` of the SEG3 quadratics of :func:`edge_roots`, wherever they
    are (NaN: none, or one for a linear edge)."""
    A = 0.5 * (phi_a + phi_b) - phi_m
    B = 0.5 * (phi_b - phi_a)
    C = phi_m
    roots = np.full((len(A), 2), np.nan)
    scale = np.abs(phi_a) + np.abs(phi_b) + np.abs(phi_m)
    lin = np.abs(A) <= 1e-14 * scale
    with np.errstate(divide="ignore", invalid="ignore"):
        r = -C / B
        roots[lin, 0] = np.where(np.abs(B[lin]) > 0, r[lin], np.nan)
        disc = B * B - 4 * A * C
        q = -0.5 * (B + np.copysign(np.sqrt(np.maximum(disc, 0.0)), B))
        r1 = q / A
        r2 = np.where(q != 0, C / q, 0.0)
        quad = ~lin & (disc >= 0)
        roots[quad, 0] = np.minimum(r1, r2)[quad]
        roots[quad, 1] = np.maximum(r1, r2)[quad]
    return roots


def edge_crossing(phi_a: FloatArray, phi_b: FloatArray, phi_m: FloatArray) -> FloatArray:
    """Where LN crosses zero inside SEG3 edges whose vertices have strictly opposite
    signs: the reference abscissa in (-1, 1) of the edge quadratic's one root there,
    NaN on the other edges.  The cut cells (:func:`xfemcontact.xfem.cut.intersection_points`)
    and the loads on cut boundary edges take the crossing from here."""
    crossing = np.asarray(phi_a) * np.asarray(phi_b) < 0
    return np.where(crossing, edge_roots(phi_a, phi_b, phi_m)[:, 0], np.nan)


@dataclass
class Readjustment:
    """What the readjustment rules changed, counted on the owned nodes."""
    roundoff: int = 0
    fitted_vertices: int = 0
    lifted_edges: int = 0
    max_lift: float = 0.0    # largest change of a mid-node value
    pushed_off: int = 0      # lifted edges whose zero line was pushed off the edge
    double_crossings: int = 0   # 3-D: edges crossed twice that keep their values (cut3d splits them)


def _mesh_edges(mesh: LocalMesh) -> IntArray:
    """Unique edges of the local cells: ``(k, 3)`` local nodes (a, b, mid)."""
    e = mesh.cell_nodes[:, mesh.element.edges].reshape(-1, 3)
    _, first = np.unique(e[:, 2], return_index=True)
    return e[first]


def cell_max_at_nodes(cell_nodes: IntArray, values: FloatArray) -> FloatArray:
    """Per node, the largest of ``values`` over the nodes of the cells holding it
    (0 for nodes of no cell).  ``cell_nodes (nc, nn)``, ``values (n,)`` >= 0.

    The cell maxima are grouped by node through SciPy's CSR -> CSC conversion (a
    counting sort in C) and reduced with ``np.maximum.reduceat``: several times
    faster than ``np.maximum.at`` or an argsort.
    """
    import scipy.sparse as sp

    nc, nn = cell_nodes.shape
    out = np.zeros(len(values))
    if nc == 0:
        return out
    cmax = values[cell_nodes].max(axis=1)
    by_cell = sp.csr_matrix((np.repeat(cmax, nn), cell_nodes.ravel(), np.arange(0, nc * nn + 1, nn)),
                            shape=(nc, len(values)))
    by_node = by_cell.tocsc()
    held = np.diff(by_node.indptr) > 0
    out[held] = np.maximum.reduceat(by_node.data, by_node.indptr[:-1][held])
    return out


def readjust(mesh: LocalMesh, phi: ArrayLike, push_off: BoolArray | None = None,
             lift_double_crossings: bool = True) -> tuple[FloatArray, Readjustment]:
    """Apply the readjustment rules; returns ``(phi, Readjustment)``.

    ``push_off``: optional ``(n,)`` bool, mid-nodes whose edge gets its zero line
    pushed off (rule 3) instead of left tangent.  ``lift_double_crossings``: False in
    3-D, where the cutting follows edges crossed twice (rule 3 then lifts tangencies only).

    Decisions at nodes shared by several processes are combined so that every
    process ends with the same values.
    """
    phi = np.array(phi, dtype=float)
    info = Readjustment()
    edges = _mesh_edges(mesh)
    a, b, m = edges.T
    # 1. round-off, relative to the largest value in the cells holding the node
    scale = reduce_nodes(mesh, cell_max_at_nodes(mesh.cell_nodes, np.abs(phi)), "max")
    tiny = (np.abs(phi) <= ROUNDOFF * scale) & (phi != 0)
    info.roundoff = int((tiny & mesh.node_owned).sum())
    phi[tiny] = 0.0
    # 2. fit to vertex: a vertex the interface runs along an edge from, or a lone one very near
    roots = quadratic_roots(phi[a], phi[b], phi[m])
    near = _near_vertices(mesh, len(phi), a, b, roots, FIT_TO_VERTEX) & (phi != 0)
    along = (near[a] | near[b]) & (near[a] | (phi[a] == 0)) & (near[b] | (phi[b] == 0))
    flag = np.zeros(len(phi), dtype=np.int64)
    flag[a[along]] = 1
    flag[b[along]] = 1
    flag = (reduce_nodes(mesh, flag, "max").astype(bool) & near) | _near_vertices(mesh, len(phi), a, b, roots, FIT_LONE_VERTEX)
    flag &= phi != 0
    info.fitted_vertices = int(flag[: mesh.n_vertices][mesh.node_owned[: mesh.n_vertices]].sum())
    phi[flag] = 0.0
    on_edge = (phi[a] == 0) & (phi[b] == 0) & (np.abs(phi[m]) <= 2 * FIT_TO_VERTEX * scale[m])
    phi[m[on_edge]] = 0.0
    # 3. one crossing per edge
    push = np.zeros(len(m), bool) if push_off is None else np.asarray(push_off)[m]
    phi_m, lifted, kept = _lift_double_crossings(phi[a], phi[b], phi[m], push, lift_double_crossings)
    owned = mesh.node_owned[m]                   # count each edge once over the processes
    info.double_crossings = int((kept & owned).sum())
    info.lifted_edges = int((lifted & owned).sum())
    info.pushed_off = int((lifted & push & owned).sum())
    if lifted.any():
        info.max_lift = float(np.abs(phi_m - phi[m]).max())
    phi[m] = phi_m
    return phi, info


def _near_vertices(mesh: LocalMesh, n: int, a: IntArray, b: IntArray, roots: FloatArray,
                   tol: float) -> BoolArray:
    """Nodes that are the vertex of an edge ``(a, b)`` with a root of its quadratic (``roots
    (k, 2)``, :func:`quadratic_roots`, reference abscissae, the edge is [-1, 1]) on the edge
    within ``tol`` of the edge's length from the vertex, on any process (``n`` local nodes).
    The roots within round-off of a vertex count (:func:`edge_roots` drops them): a vertex
    whose LN is not zero but whose edges take it for a root must be fitted, or the cut
    cells would find no zero near it."""
    with np.errstate(invalid="ignore"):
        at_a = (roots >= -1.0) & (roots <= -1.0 + 2 * tol)
        at_b = (roots <= 1.0) & (roots >= 1.0 - 2 * tol)
    flag = np.zeros(n, dtype=np.int64)
    flag[a[np.any(at_a, axis=1)]] = 1
    flag[b[np.any(at_b, axis=1)]] = 1
    return reduce_nodes(mesh, flag, "max").astype(bool)


def _lift_double_crossings(pa: FloatArray, pb: FloatArray, pm: FloatArray, push_off: BoolArray,
                           lift_all: bool = True) -> tuple[FloatArray, BoolArray, BoolArray]:
    """Mid-node values making each edge quadratic cross zero at most once.

    ``push_off (k,)`` bool: on these edges, if their vertices have one sign and
    the quadratic sags towards zero between them, push the zero line off the
    edge (the quadratic becomes monotone).  Without ``lift_all`` (3-D), edges whose
    vertices have one sign and whose two crossings are more than ``2 FIT_TO_VERTEX`` apart
    (in the edge's abscissa from 0 to 1) keep their values.  Returns ``(values, lifted,
    kept)``: the new mid-node values, the edges lifted and the double crossings kept.
    """
    roots = edge_roots(pa, pb, pm)
    n_inner = np.sum(~np.isnan(roots), axis=1)
    at_vertex = (pa == 0) | (pb == 0)
    same = (pa * pb > 0)
    kept = np.zeros(len(pa), bool)
    if not lift_all:
        with np.errstate(invalid="ignore"):
            kept = same & (n_inner == 2) & (0.5 * (roots[:, 1] - roots[:, 0]) > 2 * FIT_TO_VERTEX)
    bad = (same & (n_inner >= 1) & ~kept) | (at_vertex & ~((pa == 0) & (pb == 0)) & (n_inner >= 1))
    # With u = |values| >= 0 on the edge, the quadratic through (ua, c, ub) has the
    # minimum value 0 (a double root) for c = (sqrt(ua) -+ sqrt(ub))^2 / 4: with
    # "-" at s* = (sqrt(ua) - sqrt(ub)) / (sqrt(ua) + sqrt(ub)) on the edge, the
    # least change (the interface stays tangent to the edge); with "+" at
    # |s*| >= 1, monotone on the edge, which pushes the zero line off it.
    s = np.where(pa + pb > 0, 1.0, -1.0)                 # sign of the edge's values
    ua, ub = np.abs(pa), np.abs(pb)
    off = 0.25 * (np.sqrt(ua) + np.sqrt(ub)) ** 2
    lifted = bad | (push_off & (same | at_vertex) & (s * pm < off))
    c = np.where(push_off, off, 0.25 * (np.sqrt(ua) - np.sqrt(ub)) ** 2)
    c += 1e-14 * (ua + ub)                 # no round-off dip below zero at s*
    lifted &= ~kept
    return np.where(lifted, s * c, pm), lifted, kept


def double_crossed_cells(mesh: LocalMesh, phi: FloatArray) -> BoolArray:
    """Cells ``(nc,)`` with an edge whose vertices have one strict sign while its quadratic
    crosses zero twice inside (the edges rule 3 keeps in 3-D, ``lift_double_crossings =
    False``): cut, whatever the signs of their nodes."""
    e = mesh.cell_nodes[:, mesh.element.edges]                                # (nc, ne, 3): a, b, mid
    pa, pb, pm = (phi[e[..., i]].ravel() for i in range(3))
    inner = (~np.isnan(edge_roots(pa, pb, pm))).sum(axis=1) == 2
    return (inner & (pa * pb > 0)).reshape(e.shape[:2]).any(axis=1)


def classify(mesh: LocalMesh, phi: FloatArray, cut: BoolArray | None = None) -> IntArray:
    """Side of every local cell: -1, +1, or 0 for cut cells (and for the cells ``cut (nc,)``,
    if given: :func:`double_crossed_cells`)."""
    pc = phi[mesh.cell_nodes]
    pos = (pc > 0).any(axis=1)
    neg = (pc < 0).any(axis=1)
    side = np.where(pos & neg, 0, np.where(pos, 1, -1))
    if cut is not None:
        side[cut] = 0
    zero = ~pos & ~neg
    if zero.any():
        c = int(np.nonzero(zero)[0][0])
        raise GeometryError(f"level set: LN = 0 at every node of cell {mesh.cell_ids[c]} "
                            f"near ({mesh.x[mesh.cell_nodes[c]].mean(0)[0]:.6g}, "
                            f"{mesh.x[mesh.cell_nodes[c]].mean(0)[1]:.6g}): the interface is not a curve there")
    _check_islands(mesh, phi, side)
    return side


def _check_islands(mesh: LocalMesh, phi: FloatArray, side: IntArray) -> None:
    """Cells with nodes of one sign must not contain the other sign."""
    el = mesh.element
    q, _ = el.quadrature(4)
    pts = np.r_[q, 0.5 * (el.ref_nodes[el.edges[:, 0]] + el.ref_nodes[el.edges[:, 2]]),
                0.5 * (el.ref_nodes[el.edges[:, 1]] + el.ref_nodes[el.edges[:, 2]])]
    unc = np.nonzero(side != 0)[0]
    vals = phi[mesh.cell_nodes[unc]] @ el.shape(pts).T          # (k, npts)
    wrong = np.any(vals * side[unc, None] < 0, axis=1)
    if wrong.any():
        c = unc[np.nonzero(wrong)[0][0]]
        ctr = mesh.x[mesh.cell_nodes[c]].mean(0)
        if len(ctr) == 3:
            raise GeometryError(f"level set: the interface makes a closed surface inside cell "
                                f"{mesh.cell_ids[c]} near ({ctr[0]:.6g}, {ctr[1]:.6g}, {ctr[2]:.6g}), "
                                f"or crosses one of its faces without crossing its edges: refine the mesh there")
        raise GeometryError(f"level set: the interface makes a closed curve inside cell "
                            f"{mesh.cell_ids[c]} near ({ctr[0]:.6g}, {ctr[1]:.6g}), smaller than "
                            f"the cell: refine the mesh there")


def edge_point(xe: FloatArray, s: ArrayLike) -> FloatArray:
    """Physical point at reference abscissa ``s`` of SEG3 edges ``xe (k, 3, 2)``."""
    return np.einsum("ka,kai->ki", Seg3.shape(s), xe)
