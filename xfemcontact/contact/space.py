"""The contact multiplier space: LAGS_C and LAGS_F1 on vertices, made unique.

Raw space (code_aster ALGO_LAGR='NON'): one LAGS_C and one LAGS_F1 per vertex of
each cut cell, interpolated on the interface with the cell's linear companion
functions (TRIA3 / QUAD4).  On a curved interface its trace is rich (linear or
bilinear functions restricted to a curve) and approximates the contact pressure
well, but two things spoil it:

* *weak vertices*: a vertex whose linear function is almost zero on the whole
  interface (the interface clips a corner of a cell, or passes a few
  thousandths of h from a neighbouring vertex) has a nearly free multiplier:
  the discrete inf-sup constant collapses, MUMPS meets tiny pivots and the
  pressure oscillates;
* *kernels*: where the interface is straight, the vertex interpolant of the
  signed distance has an identically zero trace (one such vector per
  connected set of crossed edges, one per crossed edge of axis-aligned
  quadrangles): the matrix is singular.

We build the space in two steps, both decided from data gathered from every
process and keyed by input node indices, so that it does not depend on the
partition:

1. *Aggregation of weak vertices.*  The weight of a vertex is the largest value
   of its linear function at the interface points (intersection and Gauss
   points) of its cut cells.  Vertices with weight below ``WEAK`` carry no
   multiplier: their value is the extrapolation of the field of the nearest
   *root* cell (a cut cell whose vertices all carry multipliers): the root's
   P1 / Q1 field evaluated at the weak vertex.  The multiplier stays
   continuous, linear fields stay exact, and no
   free dof is left with a vanishing trace.  (code_aster's "locally inactive"
   vertices redistribute weights equally inside each cell instead: exact for
   constants only, discontinuous.)
2. *Kernel ties.*  The crossed edges link the carrying vertices into packets.
   For each packet we compute the smallest eigenvalue of its trace Gram matrix
   (diagonally scaled); while it is below ``KERNEL`` the two ends of the
   packet's edge crossed nearest its middle are merged (code_aster VERSION3,
   ELIM_ARETE='ELIM': one shared dof, no extra unknown).  On curved interfaces
   nothing is merged and the accuracy of the raw space is kept; on straight
   ones exactly the kernel is removed.  Carriers whose traces are the same
   function (a straight interface along quadrangle diagonals: the two corners
   off the line) are merged too, and so are crossed edges while a set of
   carriers sharing cut cells is still singular.
3. *Gradient ties.*  The tie of a packet that is weak but not singular (a
   locally flat spot of a curved interface, on quadrangles) becomes
   lam_a = lam_b + (x_a - x_b) . g, g the multiplier's gradient read from the
   neighbouring crossed edges: the weak mode goes, linear fields stay exact,
   where a merge would force zero variation along the edge.  The reported
   smallest eigenvalue is that of the packet with the merge.  Neighbouring
   ties (a flat stretch) may take each other's roots: every tie is finally
   written in free carriers.  A gradient tie keeps linear fields, the signed
   distance of a straight stretch among them, whose trace is zero: where the
   final space has a kernel again, the ties of that set go back to merges.

Merged vertices share the dof held by the representative (the smallest input
node index of the class).

In 3-D (:func:`build3d`) the interface elements are the cut cells (their facets)
and the cells owning an interface lying on a face; the raw space and step 1 are
the same (P1 / Q1 vertex functions of TETRA10 / HEXA20, weak vertices
extrapolated from their nearest full cell), with one more kind of root: a *root
face*, a face of an interface cell whose vertices all carry multipliers, whose
TRIA3 / QUAD4 field a weak vertex takes at its projection on the face where the
face is ``FACE_ROOT_RATIO`` times nearer than any full cell, or no cell is full
(:func:`_aggregation3d`).  That is an interface lying along a plane of vertices (a
thin cap a few hundredths of h above it, bench/contact3d_caps.py): the cells on
either side hold weak vertices only, whose traces are nearly those of the plane's
vertices times a small factor; left carriers, as before, they were weakly
controlled modes the merges below did not remove (dofs up to -4.3e6 Pa for -100,
6 to 14 of them open on 3 x 3 x 3 and 6 x 6 x 6 boxes).  Step 2 is done on the trace Gram
matrix directly, with merges only: on each set of carriers sharing interface
elements the eigenvectors of the (scaled) Gram matrix below ``KERNEL_3D`` span
the kernel; crossed edges (nearest their middle first, then the least ids), then
any edge of an interface cell, are merged while the merge is not already
satisfied by every kernel vector, each merge removing one kernel dimension
(exactly: the kernel of the merged space is the part of the kernel that satisfies
the merges).  A set whose merges leave a mode below ``KERNEL_3D`` without raising its
smallest eigenvalue ``MERGE_GAIN`` times (a curved interface, whose nearly invisible
modes merges do not remove) keeps only the merges of its true kernels (below
``SINGULAR``).  Why: a plane has one kernel per set
(the signed distance, P1 and Q1 reproduce it), but an axis-aligned plane on hexahedra
has a kernel as large as half of the vertices (trilinear functions vanishing on a plane
z = c), and the packets of 2-D (chains of crossed edges) are whole interfaces in 3-D;
reading the kernel once and updating it merge by merge costs one dense eigenvalue
problem per set (two where the merges are undone).  Merges keep linear fields exact (the
merged values of an edge crossing the interface can be met by adding a multiple of the
signed distance), except where several merges meet in one class.  No gradient ties in
3-D.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Collection

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from xfemcontact.fem import elements

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.fem.elements import Element
    from xfemcontact.mesh.plex import LocalMesh
    from xfemcontact.xfem.cut import Segments

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]
    #: a vertex given by others: global id -> (root global ids (r,), weights (r,))
    Combinations = dict[int, tuple[IntArray, FloatArray]]
    #: a scipy.sparse matrix (SciPy has no type information here)
    Sparse = Any

#: least interface weight of a vertex carrying multipliers, by cell type: measured
#: on sweeps of the SSNV509 arc across the mesh (bilinear traces on QUAD8 keep
#: useful information down to smaller weights than linear ones on TRIA6)
WEAK = {"QUAD8": 0.02, "TRIA6": 0.05, "HEXA20": 0.05, "TETRA10": 0.1}
#: (3-D: measured on a sphere in a box under a uniform stress that sticks everywhere,
#: N = 4 and 8: with 0.02 / 0.05 the dof values of LAGS_C spread from -358 to 0 Pa for
#: point values of -150 to -100 Pa (weakly controlled dofs: a dof opened, another slid
#: with mu = 10, and the threshold loop did not converge on HEXA20 N = 4), max error
#: 13.7 Pa on TETRA10 N = 8; with 0.05 / 0.1 -215 to -48, and 3.1 Pa)

#: 3-D: a weak vertex extrapolates its nearest root face (:func:`_face_aggregation`)
#: instead of its nearest full cell only when the cell's centroid is this many times
#: farther than the face's.  Measured (bench/contact3d_caps.py, bench/contact3d_sphere.py):
#: where no interface cell is full (caps just above a plane of vertices) faces are the only
#: roots and remove the weakly controlled dofs; faces in competition with full cells on
#: equal terms (ratio 1) made the sphere's L2 error of LAGS_C 1.153 Pa instead of 1.027 on
#: HEXA20 N = 4 (0.349 / 0.335 at N = 8; a face's extrapolation has no normal gradient,
#: which a curved interface sees); with 2 the sphere (N = 4, 8) was unchanged but the cap
#: R = 2 m on HEXA20 N = 6 (which has full cells) went from 1.3e-4 p to 3.9e-4 p; with 4
#: every case of both benches with a full cell near its weak vertices is unchanged
FACE_ROOT_RATIO = 4.0

#: relative singular value below which a direction of the crossed edges around a gradient
#: tie is left out of its gradient (step 3).  Nearly parallel edges (distorted quadrangles)
#: determine the gradient across them badly: on gmsh_quad8_10x10.msh the arc's only tie had
#: weights summing to 8.8 and gave a dof the lumped weight -1.33 (against 1.75), whose point
#: gaps dipped to -5.7e-9 m (5.7e-3 of the displacements) between converged dofs; with this
#: cut its weights sum to 0.98, the lumped weight is -0.07 and the point gaps -6e-10 m.  Ties
#: whose edges span the plane (SSNV509 a's, weights summing to 1.0) are unchanged.
GRADIENT_RCOND = 0.1
#: scaled trace eigenvalue below which a packet is tied, by cell type.  On
#: quadrangles a packet is usually one crossed edge whose "curvature" mode is
#: nearly invisible where the interface is locally flat (the bottom of an arc):
#: weakly controlled, it makes the pressure spike at one point when statuses or
#: sliding let it (measured: frictionless SSNV509); tying it costs local accuracy
#: only.  On triangles a packet is a long chain of crossed edges whose smallest
#: eigenvalue measures the chain as a whole: only true kernels are tied.
KERNEL = {"QUAD8": 1e-3, "TRIA6": 1e-10}
#: 3-D (:func:`build3d`): scaled trace eigenvalue below which a mode of a set of
#: carriers sharing cut cells is removed by merges.  HEXA20: trilinear functions
#: restricted to a nearly axis-aligned surface have nearly invisible modes (on an
#: axis-aligned plane half of the vertex values are a kernel), tied like the weak
#: packets of quadrangles; TETRA10: only true kernels (the signed distance of a plane)
KERNEL_3D = {"HEXA20": 1e-3, "TETRA10": 1e-10}
#: 3-D: the merges of a set whose smallest eigenvalue stays below ``KERNEL_3D`` are kept
#: when they raise it at least this many times (:func:`_merge_kernels`)
MERGE_GAIN = 2.0
#: 3-D: a vertex function whose largest value on the interface is at most this is zero there
ZERO_TRACE = 1e-12
#: below this a packet is singular (straight interface): its ties stay merges
SINGULAR = 1e-10


@dataclass
class SegmentTopology:
    """Where the interface meets the boundary of each owning cell."""

    cut_edges: IntArray        # (k, e, 2) global ids (a, b) of the crossed edges (2-D: of P1, P2; -1: none)
    r: FloatArray              # (k, e) position of the crossing on that edge from a, in (0, 1)
    verts: IntArray            # (k, nv) global ids of the cell's vertices
    xv: FloatArray             # (k, nv, d) vertex coordinates, m


def topology(mesh: LocalMesh, segments: Segments) -> SegmentTopology:
    """SegmentTopology of ``segments`` (cut.Segments) of local cells."""
    el = mesh.element
    k = len(segments)
    vnodes = mesh.cell_nodes[segments.cells, : el.nv]
    verts = mesh.node_ids[vnodes]
    cut_edges = np.full((k, 2, 2), -1, dtype=np.int64)
    r = np.full((k, 2), np.nan)
    rows = np.arange(k)
    for i in range(2):
        w = segments.where[:, i]
        on_edge = w >= 0
        e = np.maximum(w, 0)
        a, b = el.edges[e, 0], el.edges[e, 1]
        ra, rb = el.ref_nodes[a], el.ref_nodes[b]
        frac = np.linalg.norm(segments.nodes[:, i] - ra, axis=-1) / np.linalg.norm(rb - ra, axis=-1)
        cut_edges[on_edge, i, 0] = verts[rows[on_edge], a[on_edge]]
        cut_edges[on_edge, i, 1] = verts[rows[on_edge], b[on_edge]]
        r[on_edge, i] = frac[on_edge]
    return SegmentTopology(cut_edges, r, verts, mesh.x[vnodes])


@dataclass
class MultiplierSpace:
    """The multiplier space (see the module documentation)."""

    ids: IntArray              # sorted global ids of every carrying vertex (all processes)
    rep: IntArray              # representative global id of each
    topo: SegmentTopology      # of this process's segments
    carriers_of: IntArray      # (k, m) carrier global ids used by each segment cell (-1 pad)
    T: FloatArray              # (k, nv, m) vertex values = T @ carrier values
    T_convex: FloatArray       # (k, nv, m) the same with weak vertices as convex combinations
    n_packets: int = 0
    n_ties: int = 0
    n_weak: int = 0
    smallest: float = np.inf   # smallest scaled trace eigenvalue over the packets, after ties
    algo: str = "AUTO"
    #: [(a, b, packet eigenvalue)], global ids
    tie_edges: list[tuple[int, int, float]] = field(default_factory=list)
    #: global ids of the vertices given by gradient ties (step 3), sorted
    gradient_tied: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def representative(self, gids: IntArray) -> IntArray:
        """Representative global ids of carriers ``gids`` (any shape)."""
        return self.rep[np.searchsorted(self.ids, gids)]

    def carriers(self, mesh: LocalMesh) -> BoolArray:
        """(n,) bool: local vertices holding multiplier dofs (representatives)."""
        out = np.zeros(len(mesh.x), dtype=bool)
        out[: mesh.n_vertices] = np.isin(mesh.node_ids[: mesh.n_vertices], np.unique(self.rep))
        return out

    def functions(self, lin: FloatArray) -> FloatArray:
        """Multiplier functions ``(k, ..., m)`` from linear companion values ``lin (k, ..., nv)``."""
        return np.einsum("k...v,kvm->k...m", lin, self.T)

    def summary(self) -> dict[str, Any]:
        """What results.json says about the space."""
        return {"algo_lagr": self.algo,
                "carriers": int(len(np.unique(self.rep))),
                "weak_vertices": self.n_weak, "packets": self.n_packets, "ties": self.n_ties,
                "smallest_trace_eigenvalue": float(self.smallest)}


def build(mesh: LocalMesh, segments: Segments, algo: str = "AUTO",
          lin_at_points: FloatArray | None = None,
          weights: FloatArray | None = None) -> MultiplierSpace:
    """The multiplier space of the interface ``segments`` (all of this process's).

    ``lin_at_points (k, ng, nv)``: linear companion functions at the segments'
    Gauss points, ``weights (k, ng)`` their weights (m).  Besides ``T`` (weak
    vertices extrapolated, weak packets tied by gradient: exact for linear
    fields) the space has ``T_convex``, the same vertices as convex combinations
    (weak vertices: :func:`convex_weights` of their roots; ties: merges), the
    admissible alternative used where an extrapolated value is not
    (:mod:`xfemcontact.contact.nodal_problem`).
    """
    el = mesh.element
    nv = el.nv
    topo = topology(mesh, segments)
    ends = el.shape_linear(segments.nodes[:, :2])                              # (k, 2, nv)
    local_w = np.max(np.concatenate([ends, lin_at_points], axis=1), axis=1)     # (k, nv)
    space, (edges, r, ids, xv, strong, ext, cverts) = _raw_space(mesh, topo, local_w, algo)
    if algo != "NON" and len(space.ids):
        assert lin_at_points is not None and weights is not None      # needed by the ties
        _tie_kernels(space, mesh, edges, r, lin_at_points, weights)
        if algo == "STABLE":                     # its ties are merges by design
            return space
        merged: set[tuple[int, int]] = set()
        while space.tie_edges:
            tied = _gradient_ties(space, topo, nv, ids, xv, strong, ext, edges, cverts, merged)
            kernel = _kernel_carriers(tied, mesh, lin_at_points, weights)
            more = {(a, b) for a, b, _ in space.tie_edges
                    if kernel & set(cverts[np.isin(cverts, [a, b]).any(axis=1)].ravel().tolist())} - merged
            if not more:
                return tied
            merged |= more           # gradient ties that bring a kernel back go back to merges
    return space


def _raw_space(mesh: LocalMesh, topo: SegmentTopology, local_w: FloatArray,
               algo: str) -> tuple[MultiplierSpace, tuple[Any, ...]]:
    """The space of every strong vertex of every process's cut cells, weak vertices
    aggregated (step 1 of the module documentation), both dimensions.  ``local_w (k,
    nv)``: the largest value of each vertex's linear function on this process's
    interface points.  Returns the space and the gathered data the ties need:
    ``(edges (E, 2), r (E,), ids, xv, strong, ext, cverts)``."""
    el = mesh.element
    mpi = mesh.comm.tompi4py()
    parts = mpi.allgather((topo.cut_edges.reshape(-1, 2), topo.r.reshape(-1), topo.verts,
                           topo.xv, local_w))
    edges = np.concatenate([p[0] for p in parts])
    r = np.concatenate([p[1] for p in parts])
    cverts = np.concatenate([p[2] for p in parts])          # (K, nv) every cut cell
    cx = np.concatenate([p[3] for p in parts])              # (K, nv, d)
    cw = np.concatenate([p[4] for p in parts])
    ids, first = np.unique(cverts.ravel(), return_index=True)
    xv = cx.reshape(-1, cx.shape[-1])[first]
    weight = np.zeros(len(ids))
    np.maximum.at(weight, np.searchsorted(ids, cverts.ravel()), cw.ravel())
    strong = weight >= WEAK[el.name] if algo != "NON" else np.ones(len(ids), bool)
    if mesh.dim == 3:
        ext = _aggregation3d(el, ids, xv, strong, weight, cverts, cx)
    else:
        ext = _aggregation(el, ids, xv, strong, cverts, cx)      # weak id -> (root ids, weights)
    if mesh.dim == 3 and not ext and not strong.all():
        # no interface cell has all its vertices strong (a plane through vertices of a
        # few cells): the weak vertices whose functions are not zero on the interface
        # stay carriers, and the merges of the kernel step remove their weak modes
        # (dropped, they left constants out of the space); those whose functions are
        # zero there (the far vertices of a cell owning an interface face) carry nothing
        strong = weight > ZERO_TRACE
    carriers = ids[strong]
    carriers_of, T = _cell_maps(topo, el.nv, strong, ids, ext)
    T_convex = _cell_maps(topo, el.nv, strong, ids, convex_aggregation(ext, xv, ids))[1]
    space = MultiplierSpace(carriers, carriers.copy(), topo, carriers_of, T, T_convex, algo=algo,
                            n_weak=int((~strong).sum()))
    return space, (edges, r, ids, xv, strong, ext, cverts)


def convex_weights(points: FloatArray, target: FloatArray) -> FloatArray:
    """Non-negative weights ``w (r,)`` summing to 1 with ``w @ points`` closest to
    ``target (d,)``: the barycentric coordinates of ``target`` when it lies in the
    convex hull of ``points (r, d)`` (then linear fields are reproduced exactly),
    else those of the hull's point nearest to it.  One small NNLS problem."""
    from scipy.optimize import nnls

    scale = max(float(np.ptp(points, axis=0).max(initial=0.0)), 1e-300)
    big = 1e3
    A = np.vstack([(points - target).T / scale, big * np.ones(len(points))])
    b = np.r_[np.zeros(points.shape[1]), big]
    w, _ = nnls(A, b)
    return w / w.sum()


def _kernel_carriers(space: MultiplierSpace, mesh: LocalMesh, lin_at_points: FloatArray,
                     weights: FloatArray) -> set[int]:
    """Global ids of the carriers of every set of carriers sharing cut cells whose
    trace Gram matrix, with the space's merges, is singular (scaled eigenvalue
    below ``SINGULAR``).  A gradient tie keeps linear fields exact, and on a
    straight stretch the interpolant of the signed distance is such a field with
    a zero trace: the kernel the packet ties removed can come back.

    (Gradient ties can also make a dof's lumped weight int phi_a ds negative where
    the neighbouring crossed edges are nearly parallel: -1.33 for a largest 1.75 on
    a Gmsh quadrangle mesh.  Merging those ties instead cost the SSNV509 a arc
    sweep its 1e-5 on LAGS_C (1.5e-5) and the nearly flat arc its exactness (1e-8
    -> 1.2e-6), for 120 instead of 212 Newton iterations on the one sliding case
    concerned: they are kept, and merged only where statuses are in play:
    :meth:`xfemcontact.contact.nodal_problem.NodalContactProblem._positive_weights`.)"""
    G = _gram(space, mesh, lin_at_points, weights)
    root = np.searchsorted(space.ids, space.rep)
    ncomp, comp = connected_components(G != 0, directed=False)
    bad = []
    for c in range(ncomp):
        members = np.nonzero(comp == c)[0]
        if len(members) > 1 and _merged_eigenvalue(G[members][:, members], members, root) < SINGULAR:
            bad.append(space.ids[members])
    return set(np.concatenate(bad).tolist()) if bad else set()


def _gradient_ties(space: MultiplierSpace, topo: SegmentTopology, nv: int, ids: IntArray,
                   xv: FloatArray, strong: BoolArray, ext: Combinations, edges: IntArray,
                   cverts: IntArray, keep: Collection[tuple[int, int]] = frozenset()) -> MultiplierSpace:
    """Turn the ties of weak (not singular) packets into gradient ties; a new space.

    A merge tie (a, b) forces lam_a = lam_b: no variation of the multiplier along
    the edge, which costs accuracy where the pressure varies.  A gradient tie sets
    lam_a = lam_b + (x_a - x_b) . g, g the least-squares gradient of the multiplier
    read from the other crossed edges of the cells holding (a, b): exact for linear
    fields, and it still removes the edge's own weak mode.  Ties of singular packets
    (eigenvalue below ``SINGULAR``: straight interfaces, whose kernel *is* a linear
    field), ties without a neighbouring crossed edge and the ties of ``keep``
    (pairs of global ids) stay merges.

    In ``T_convex`` of the new space the gradient ties are merges lam_a = lam_b.
    """
    pos = {g: i for i, g in enumerate(ids)}
    cell_edges = edges.reshape(-1, 2, 2)
    tied: Combinations = {}
    nb: Collection[tuple[int, ...]]
    for a, b, lam in space.tie_edges:
        if lam < SINGULAR or a in tied or b in tied or (a, b) in keep:
            continue
        in_cells = np.nonzero(np.isin(cverts, [a, b]).sum(axis=1) == 2)[0]
        nb = {tuple(sorted(e)) for c in in_cells for e in cell_edges[c] if e[0] >= 0}
        nb = [e for e in nb if set(e) != {a, b} and all(strong[pos[v]] and v not in tied for v in e)]
        if not nb:
            continue
        D = np.array([xv[pos[p]] - xv[pos[q]] for p, q in nb])
        # (directions the crossed edges barely span are left out of the gradient: nearly
        # parallel edges on distorted quadrangles made weights up to 4.7 and a negative
        # lumped weight; see GRADIENT_RCOND)
        G = np.linalg.pinv(D, rcond=GRADIENT_RCOND)                  # (2, k)
        w = (xv[pos[a]] - xv[pos[b]]) @ G                            # (k,)
        roots, wts = [b], [1.0]
        for (p, q), wk in zip(nb, w):
            roots += [p, q]
            wts += [wk, -wk]
        tied[a] = (np.array(roots), np.array(wts))
    # A tie's roots were free when it was made, but a later tie may take one of them
    # (neighbouring edges of a flat stretch): express every tie in free carriers,
    # latest first, so that each substitution uses ties already resolved.
    for a in reversed(list(tied)):
        tied[a] = _substitute(*tied[a], tied)
    strong = strong.copy()
    for a in tied:
        strong[pos[a]] = False
    merged = {a: (roots[:1], np.ones(1)) for a, (roots, _) in tied.items()}
    convex = convex_aggregation(ext, xv, ids)
    ext = {g: _substitute(roots, wts, tied) for g, (roots, wts) in ext.items()}
    ext.update(tied)
    convex = {g: _substitute(roots, wts, merged) for g, (roots, wts) in convex.items()}
    convex.update(merged)
    carriers_of, T = _cell_maps(topo, nv, strong, ids, ext)
    carriers_of_c, T_convex = _cell_maps(topo, nv, strong, ids, convex)
    T_convex = _same_columns(carriers_of, carriers_of_c, T_convex)
    carriers = ids[strong]
    new = MultiplierSpace(carriers, carriers.copy(), topo, carriers_of, T, T_convex, algo=space.algo,
                          n_weak=space.n_weak, n_packets=space.n_packets, n_ties=space.n_ties,
                          smallest=space.smallest)
    new.gradient_tied = np.array(sorted(tied), dtype=np.int64)
    for a, b, _ in space.tie_edges:                 # the ties that stay merges
        if a not in tied and b not in tied:
            new.rep[new.rep == max(a, b)] = min(a, b)
    return new


def _substitute(roots: IntArray, wts: FloatArray, tied: Combinations) -> tuple[IntArray, FloatArray]:
    """``(roots, weights)`` of an extrapolated vertex with every tied root replaced by its own."""
    rr, ww = [], []
    for r, w in zip(roots, wts):
        sub_roots, sub_wts = tied.get(r, ([r], [1.0]))
        rr += list(sub_roots)
        ww += list(w * np.asarray(sub_wts))
    return np.array(rr), np.array(ww)


def _aggregation(el: Element, ids: IntArray, xv: FloatArray, strong: BoolArray, cverts: IntArray,
                 cx: FloatArray) -> Combinations:
    """For every weak vertex: the vertices of its root cell and extrapolation weights.

    The weights are the root cell's own linear companion functions (P1 / Q1)
    evaluated at the weak vertex: the weak vertex continues the root's multiplier
    field, its bilinear part included.  (An affine fit of a quadrangle's four
    values drops that part: on SSNV509 a the L2-best LAGS_F1 at the arc ends was
    6 times less accurate with it.)
    """
    full = np.all(strong[np.searchsorted(ids, cverts)], axis=1)
    weak = np.nonzero(~strong)[0]
    if not full.any() or not len(weak):
        return {}
    roots = np.nonzero(full)[0]
    centre = cx[roots].mean(axis=1)
    d = np.linalg.norm(centre[None, :, :] - xv[weak, None, :], axis=2)       # (w, r)
    key = np.broadcast_to(cverts[roots].min(axis=1), d.shape)
    nearest = roots[np.lexsort((key, d), axis=1)[:, 0]]
    wts = el.shape_linear(el.linear_reference(cx[nearest], xv[weak]))          # (w, nv)
    return {ids[i]: (cverts[j], w) for i, j, w in zip(weak, nearest, wts)}


def _aggregation3d(el: Element, ids: IntArray, xv: FloatArray, strong: BoolArray, weight: FloatArray,
                   cverts: IntArray, cx: FloatArray) -> Combinations:
    """3-D step 1: every weak vertex extrapolates its nearest root, a full interface cell
    (:func:`_aggregation`) or a root face (:func:`_face_aggregation`), nearest by the
    distance from the weak vertex to the root's centroid, a face only where it is
    :data:`FACE_ROOT_RATIO` times nearer than the nearest full cell (or no cell is full):
    an interface lying along a plane of vertices, whose cells on either side hold weak
    vertices."""
    ext = _aggregation(el, ids, xv, strong, cverts, cx)
    dist: dict[int, float] = {}
    for g, comb in _face_aggregation(el, ids, xv, strong, weight, cverts, cx, dist).items():
        if g in ext:
            roots = np.searchsorted(ids, ext[g][0])
            if FACE_ROOT_RATIO * dist[g] >= np.linalg.norm(xv[roots].mean(axis=0) - xv[np.searchsorted(ids, g)]):
                continue
        ext[g] = comb
    return ext


def _face_aggregation(el: Element, ids: IntArray, xv: FloatArray, strong: BoolArray,
                      weight: FloatArray, cverts: IntArray, cx: FloatArray,
                      dist: dict[int, float] | None = None) -> Combinations:
    """3-D: for every weak vertex, the field of its nearest *root face*, a face of an
    interface cell whose vertices all carry multipliers: the face's own linear companion
    functions (TRIA3 / QUAD4) at the projection of the weak vertex on the face's plane (no
    variation along its normal).  ``dist`` (if given) receives the distances (m) from each
    weak vertex to its face's centroid.

    This is the interface lying along a plane of vertices (a thin cap a few hundredths of
    h above it): the cells on both sides hold the weak vertices (their functions at most
    a few hundredths on the interface, their traces nearly proportional to those of the
    plane's vertices), the plane's vertices are the only strong ones, often no cell is
    full, and the plane's faces carry the interface's multiplier field; a full cell's
    field, extrapolated, brings a gradient normal to the plane that the interface barely
    sees.  Nearest by the distance to the face's centroid, then the face whose vertices
    have the largest summed weight (the face the interface lies along), then the least
    ids.  Empty where no face is full."""
    fv = el.faces[:, : {"QUAD8": 4, "TRIA6": 3}[el.face_type]]              # (f, nfv)
    fverts = cverts[:, fv].reshape(-1, fv.shape[1])                         # (K f, nfv)
    fx = cx[:, fv].reshape(-1, fv.shape[1], cx.shape[-1])
    pos = np.searchsorted(ids, fverts)
    full = np.all(strong[pos], axis=1)
    weak = np.nonzero(~strong)[0]
    if not full.any() or not len(weak):
        return {}
    fverts, fx, pos = fverts[full], fx[full], pos[full]
    key, first = np.unique(np.sort(fverts, axis=1), axis=0, return_index=True)    # each face once
    fverts, fx, pos = fverts[first], fx[first], pos[first]
    centre = fx.mean(axis=1)
    d = np.linalg.norm(centre[None, :, :] - xv[weak, None, :], axis=2)            # (w, f)
    scale = max(float(np.ptp(xv, axis=0).max(initial=0.0)), 1e-300)
    d = np.round(d / scale, 9)                                                    # ties: equal distances
    wsum = np.broadcast_to(-weight[pos].sum(axis=1), d.shape)
    low = np.broadcast_to(key[:, 0], d.shape)
    nearest = np.lexsort((low, wsum, d), axis=1)[:, 0]
    face = elements.element(el.face_type)
    out: Combinations = {}
    if dist is not None:
        dist.update({int(ids[i]): float(d[n_, j]) * scale for n_, (i, j) in enumerate(zip(weak, nearest))})
    for i, j in zip(weak, nearest):
        c = fx[j].mean(axis=0)
        basis = np.linalg.svd(fx[j] - c)[2][:2]                                  # the face's plane
        xi = face.linear_reference(((fx[j] - c) @ basis.T)[None], ((xv[i] - c) @ basis.T)[None])
        out[ids[i]] = (fverts[j], face.shape_linear(xi)[0])
    return out


def convex_aggregation(ext: Combinations, xv: FloatArray, ids: IntArray) -> Combinations:
    """The weak vertices of ``ext`` (see :func:`_aggregation`) as convex combinations
    of the same roots (:func:`convex_weights`): admissible wherever the roots are,
    exact for linear fields only when the weak vertex lies in their hull."""
    pos = np.searchsorted(ids, np.asarray(list(ext), dtype=np.int64))
    return {g: (roots, convex_weights(xv[np.searchsorted(ids, roots)], xv[i]))
            for (g, (roots, _)), i in zip(ext.items(), pos)}


def _same_columns(carriers_of: IntArray, other: IntArray, T_other: FloatArray) -> FloatArray:
    """``T_other`` (columns ``other``) with its columns in the order of ``carriers_of``
    (the same carriers per cell, possibly in another order; a carrier missing from
    ``carriers_of`` must carry zero weight)."""
    out = np.zeros(carriers_of.shape[:1] + T_other.shape[1:2] + carriers_of.shape[1:])
    for j in range(other.shape[1]):
        g = other[:, j]
        hit = (carriers_of == g[:, None]) & (g[:, None] >= 0)
        col = np.argmax(hit, axis=1)
        ok = hit.any(axis=1)
        out[np.nonzero(ok)[0], :, col[ok]] += T_other[ok, :, j]
        assert np.all(np.abs(T_other[~ok, :, j]) < 1e-14), "convex map uses another carrier"
    return out


def _cell_maps(topo: SegmentTopology, nv: int, strong: BoolArray, ids: IntArray,
               ext: Combinations) -> tuple[IntArray, FloatArray]:
    """Per segment cell: carrier list ``(k, m)`` and ``T (k, nv, m)``."""
    k = len(topo.verts)
    slots: list[list[tuple[int, int, float]]] = [[] for _ in range(k)]
    for c in range(k):
        for a in range(nv):
            g = topo.verts[c, a]
            if strong[np.searchsorted(ids, g)]:
                slots[c].append((a, g, 1.0))
            elif g in ext:
                for h, w in zip(*ext[g]):
                    slots[c].append((a, h, w))
    m = max((len({g for _, g, _ in s}) for s in slots), default=nv)
    carriers_of = np.full((k, m), -1, dtype=np.int64)
    T = np.zeros((k, nv, m))
    for c, s in enumerate(slots):
        cols: dict[int, int] = {}
        for a, g, w in s:
            j = cols.setdefault(g, len(cols))
            carriers_of[c, j] = g
            T[c, a, j] += w
    return carriers_of, T


def _gram(space: MultiplierSpace, mesh: LocalMesh, lin_at_points: FloatArray,
          weights: FloatArray) -> Sparse:
    """Trace Gram matrix of the carriers, gathered from every process (sparse)."""
    phit = space.functions(lin_at_points)                                 # (k, ng, m)
    co = space.carriers_of
    idx = np.where(co >= 0, np.searchsorted(space.ids, np.maximum(co, 0)), -1)
    G = np.einsum("kq,kqa,kqb->kab", weights, phit, phit)
    rows = np.broadcast_to(idx[:, :, None], G.shape)
    cols = np.broadcast_to(idx[:, None, :], G.shape)
    ok = (rows >= 0) & (cols >= 0)
    parts = mesh.comm.tompi4py().allgather((rows[ok], cols[ok], G[ok]))
    n = len(space.ids)
    return sp.coo_matrix((np.concatenate([p[2] for p in parts]),
                          (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]))),
                         shape=(n, n)).tocsr()


def _smallest_scaled_eigenvalue(G: Sparse) -> float:
    """Smallest eigenvalue of the Jacobi-scaled Gram matrix ``G`` (sparse, SPD or singular)."""
    n = G.shape[0]
    if n == 0:
        return np.inf
    d = G.diagonal()
    s = 1.0 / np.sqrt(np.where(d > 0, d, 1.0))
    A = G.multiply(s[:, None]).multiply(s[None, :]).tocsc()
    if n <= 300:
        return sla.eigh(A.toarray(), eigvals_only=True, subset_by_index=[0, 0])[0]
    from scipy.sparse.linalg import eigsh

    # shift-invert just below 0, where a singular Gram matrix still factors
    return eigsh(A, k=1, sigma=-1e-3, which="LM", return_eigenvectors=False)[0]


def _packet_eigenvalues(G: Sparse, order: IntArray, bounds: IntArray) -> FloatArray:
    """Smallest Jacobi-scaled eigenvalue of every packet's diagonal block of ``G``.

    Packet ``c`` holds the vertices ``order[bounds[c]:bounds[c + 1]]``; packets of
    one size are solved as one batch of small dense problems.
    """
    sizes = np.diff(bounds)
    lams = np.empty(len(sizes))
    for m in np.unique(sizes):
        pk = np.nonzero(sizes == m)[0]
        if m > 300:
            for c in pk:
                members = order[bounds[c]:bounds[c + 1]]
                lams[c] = _smallest_scaled_eigenvalue(G[members][:, members])
            continue
        idx = order[bounds[pk][:, None] + np.arange(m)]                          # (k, m)
        rows = np.broadcast_to(idx[:, :, None], (len(pk), m, m)).ravel()
        cols = np.broadcast_to(idx[:, None, :], (len(pk), m, m)).ravel()
        B = np.asarray(G[rows, cols]).reshape(len(pk), m, m)
        d = np.diagonal(B, axis1=1, axis2=2)
        s = 1.0 / np.sqrt(np.where(d > 0, d, 1.0))
        lams[pk] = np.linalg.eigvalsh(B * s[:, :, None] * s[:, None, :])[:, 0]
    return lams


def _tie_kernels(space: MultiplierSpace, mesh: LocalMesh, edges: IntArray, r: FloatArray,
                 lin_at_points: FloatArray, weights: FloatArray) -> None:
    ids = space.ids
    keep = (edges[:, 0] >= 0) & np.isin(edges[:, 0], ids) & np.isin(edges[:, 1], ids)
    e, rr = edges[keep], r[keep]
    swap = e[:, 0] > e[:, 1]
    e = np.where(swap[:, None], e[:, ::-1], e)
    rr = np.where(swap, 1.0 - rr, rr)
    e, first = np.unique(e, axis=0, return_index=True)
    rr = rr[first]
    n = len(ids)
    ia, ib = np.searchsorted(ids, e[:, 0]), np.searchsorted(ids, e[:, 1])
    G = _gram(space, mesh, lin_at_points, weights)
    kernel = KERNEL[mesh.element.name]
    ncomp, comp = connected_components(sp.coo_matrix((np.ones(len(e)), (ia, ib)), shape=(n, n)),
                                       directed=False)
    space.n_packets = ncomp
    root = np.arange(n)
    order = np.argsort(comp, kind="stable")
    bounds = np.searchsorted(comp[order], np.arange(ncomp + 1))
    centrality = np.abs(rr - 0.5)
    if space.algo == "STABLE":
        root = _star_roots(ids, ia, ib, space)
        _tie_twins(space, G, root)
        space.smallest = _tie_global_kernels(space, G, e, ia, ib, centrality, root)
        space.rep = ids[root]
        return
    lams = _packet_eigenvalues(G, order, bounds)
    fine = lams >= kernel
    smallest = lams[fine].min() if fine.any() else np.inf
    for c in np.nonzero(lams < kernel)[0]:             # the few packets that need ties
        members = order[bounds[c]:bounds[c + 1]]
        cand = np.nonzero(comp[ia] == c)[0]
        cand = cand[np.lexsort((e[cand, 1], e[cand, 0], centrality[cand]))]
        local = {mbr: i for i, mbr in enumerate(members)}
        classes = np.arange(len(members))
        Gp = G[members][:, members]
        lam = lams[c]
        for j in cand:
            if lam >= kernel:
                break
            a, b = classes[local[ia[j]]], classes[local[ib[j]]]
            if a == b:
                continue
            lo, hi = min(a, b), max(a, b)
            classes[classes == hi] = lo
            space.n_ties += 1
            space.tie_edges.append((int(ids[ia[j]]), int(ids[ib[j]]), float(lams[c])))
            lam = _merged_eigenvalue(Gp, np.arange(len(members)), classes)
        smallest = min(smallest, lam)
        root[members] = members[classes]       # class label = its smallest member
    _tie_twins(space, G, root)
    smallest = min(smallest, _tie_global_kernels(space, G, e, ia, ib, centrality, root))
    space.smallest = smallest
    space.rep = ids[root]


def _star_roots(ids: IntArray, ia: IntArray, ib: IntArray, space: MultiplierSpace) -> IntArray:
    """``algo_lagr = "STABLE"``: the crossed edges ``(ia, ib)`` (indices into ``ids``) grouped
    into stars, each star's vertices one dof.  Greedy, the vertices taken by decreasing number
    of crossed edges (then input id): a vertex not in a star yet starts one with its
    neighbours across the interface that are not in one yet.  Every crossed edge then has
    both ends in one star, or joins two stars (its intersection value varies between them):
    about one dof per star centre, in the spirit of the stable spaces of Bechet, Moes and
    Wohlmuth (2009), instead of one per vertex.  Returns ``root`` (the smallest member of
    each vertex's star, as indices into ``ids``); counts the ties in ``space``."""
    n = len(ids)
    deg = np.bincount(np.concatenate([ia, ib]), minlength=n)
    a = np.concatenate([ia, ib])
    b = np.concatenate([ib, ia])
    o = np.lexsort((ids[b], a))
    a, b = a[o], b[o]
    start = np.searchsorted(a, np.arange(n + 1))
    star = np.full(n, -1)
    for v in np.lexsort((ids, -deg)):            # set-up only: one pass over the carriers
        if star[v] >= 0 or deg[v] == 0:
            continue
        star[v] = v
        leaves = b[start[v]:start[v + 1]]
        leaves = leaves[star[leaves] < 0]
        star[leaves] = v
        space.n_ties += len(leaves)
        space.tie_edges.extend((int(ids[min(v, w)]), int(ids[max(v, w)]), 0.0) for w in leaves)
    star = np.where(star < 0, np.arange(n), star)
    smallest = np.full(n, n)
    np.minimum.at(smallest, star, np.arange(n))
    return smallest[star]


def _tie_twins(space: MultiplierSpace, G: Sparse, root: IntArray) -> None:
    """Merge carriers whose traces are one and the same function.

    A straight interface through opposite corners of quadrangles (a cell
    diagonal) crosses no edge: there is no crossed edge to tie, yet the two
    corners off the line have the same trace t (1 - t) on it, so their
    difference is a kernel in every such cell.  Two carriers are twins when
    their scaled 2 x 2 Gram block is singular (correlation 1 to ``SINGULAR``);
    each pair is merged, in the order of their ids.  Updates ``root`` in place.
    """
    C = sp.triu(G, k=1).tocoo()
    d = G.diagonal()
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = C.data / np.sqrt(d[C.row] * d[C.col])
    twins = np.nonzero(1.0 - corr < SINGULAR)[0]
    ids = space.ids
    for j in twins[np.lexsort((C.col[twins], C.row[twins]))]:
        a, b = root[C.row[j]], root[C.col[j]]
        if a == b:
            continue
        root[root == max(a, b)] = min(a, b)
        space.n_ties += 1
        space.tie_edges.append((int(ids[C.row[j]]), int(ids[C.col[j]]), 0.0))


def _tie_global_kernels(space: MultiplierSpace, G: Sparse, e: IntArray, ia: IntArray, ib: IntArray,
                        centrality: FloatArray, root: IntArray) -> float:
    """Merge crossed edges until no set of carriers sharing cut cells has a kernel.

    On quadrangles a packet is often a single crossed edge, but the kernel of a
    straight interface that is not parallel to the mesh lines (the Q1
    interpolant of its signed distance) spans the vertices of whole rows of cut
    cells: every packet alone is fine, together they are singular.  The
    components of the Gram matrix's graph (carriers whose traces meet in a cut
    cell), with the packet ties in ``root`` applied, are checked; while one has
    a scaled eigenvalue below ``SINGULAR`` the ends of its crossed edge nearest
    the middle (then the least ids) are merged.  Updates ``root`` in place;
    returns the smallest eigenvalue seen after the merges.
    """
    ids = space.ids
    ncomp, comp = connected_components(G != 0, directed=False)
    smallest = np.inf
    for c in range(ncomp):
        members = np.nonzero(comp == c)[0]
        if len(members) < 2:
            continue
        Gm = G[members][:, members]
        lam = _merged_eigenvalue(Gm, members, root)
        cand = np.nonzero(comp[ia] == c)[0]
        cand = cand[np.lexsort((e[cand, 1], e[cand, 0], centrality[cand]))]
        first = lam
        for j in cand:
            if lam >= SINGULAR:
                break
            a, b = root[ia[j]], root[ib[j]]
            if a == b:
                continue
            root[root == max(a, b)] = min(a, b)
            space.n_ties += 1
            space.tie_edges.append((int(ids[ia[j]]), int(ids[ib[j]]), float(first)))
            lam = _merged_eigenvalue(Gm, members, root)
        smallest = min(smallest, lam)
    return smallest


def _merged_eigenvalue(Gm: Sparse, members: IntArray, root: IntArray) -> float:
    """Smallest scaled eigenvalue of ``Gm`` (the Gram block of ``members``) with the
    classes of ``root`` merged."""
    _, cls = np.unique(root[members], return_inverse=True)
    P = sp.csr_matrix((np.ones(len(members)), (np.arange(len(members)), cls)),
                      shape=(len(members), cls.max() + 1))
    return _smallest_scaled_eigenvalue((P.T @ Gm @ P).tocsr())


def topology3d(mesh: LocalMesh, cells: IntArray, phi: FloatArray) -> SegmentTopology:
    """:class:`SegmentTopology` of the interface cells ``cells (k,)`` (local) with LN
    ``phi`` at the local nodes: every edge whose vertices have strict opposite signs
    is crossed, at the zero of LN's linear interpolation (``r``; the ties use it for
    their order only)."""
    el = mesh.element
    vnodes = mesh.cell_nodes[cells, : el.nv]
    verts = mesh.node_ids[vnodes]
    a, b = el.edges[:, 0], el.edges[:, 1]
    pa, pb = phi[vnodes[:, a]], phi[vnodes[:, b]]                          # (k, ne)
    crossed = pa * pb < 0
    cut_edges = np.where(crossed[..., None], np.stack([verts[:, a], verts[:, b]], axis=-1), -1)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(crossed, pa / np.where(crossed, pa - pb, 1.0), np.nan)
    return SegmentTopology(cut_edges, r, verts, mesh.x[vnodes])


def build3d(mesh: LocalMesh, cells: IntArray, phi: FloatArray, lin_at_points: FloatArray,
            weights: FloatArray, algo: str = "AUTO") -> MultiplierSpace:
    """The 3-D multiplier space (see the module documentation) of the interface
    elements ``cells (k,)`` (local cells, one row per element), LN ``phi`` at the
    local nodes; ``lin_at_points (k, q, nv)`` the vertex functions at the elements'
    Gauss points, ``weights (k, q)`` their weights (m^2, 0 on padding)."""
    topo = topology3d(mesh, cells, phi)
    live = (weights != 0)[..., None]
    local_w = np.max(np.where(live, lin_at_points, 0.0), axis=1, initial=0.0)      # (k, nv)
    space, (edges, r, ids, xv, strong, ext, cverts) = _raw_space(mesh, topo, local_w, algo)
    if algo != "NON" and len(space.ids):
        _merge_kernels(space, mesh, edges, r, cverts, lin_at_points, weights)
    return space


def _merge_kernels(space: MultiplierSpace, mesh: LocalMesh, edges: IntArray, r: FloatArray,
                   cverts: IntArray, lin_at_points: FloatArray, weights: FloatArray) -> None:
    """3-D step 2 (module documentation): merges until no set of carriers sharing
    interface cells has a mode below ``KERNEL_3D``; sets ``rep``, ``n_ties``,
    ``tie_edges``, ``smallest``.  Decided on gathered data, by input ids.

    A set whose merges leave a mode below ``KERNEL_3D`` and do not raise its smallest
    eigenvalue :data:`MERGE_GAIN` times (a curved interface: its nearly invisible modes,
    about (h / R)^4 on HEXA20, are not removed by merging the vertices of crossed edges,
    and a merge forces one value along the edge) keeps only the merges of its true kernels
    (below ``SINGULAR``).  Measured on the sphere of bench/contact3d_sphere.py, HEXA20, N =
    16: 7 merges raised the smallest eigenvalue from 3.1e-4 to 3.8e-4 only and made the L2
    error of the best LAGS_C of the space 1.31 times that of the raw vertex space (1.02
    without); on nearly flat caps of large spheres (R = 2 to 20 m, h = 1/3 to 1/6 m) they
    raise it 3.6 to 10^5 times and keep LAGS_C of a uniform pressure 5 to 300 times
    closer."""
    ids = space.ids
    n = len(ids)
    G = _gram(space, mesh, lin_at_points, weights)
    kernel = KERNEL_3D[mesh.element.name]
    cand = _merge_candidates(ids, edges, r, cverts)                      # (c, 2) positions in ids
    root = np.arange(n)
    ncomp, comp = connected_components(G != 0, directed=False)
    smallest = np.inf
    for c in range(ncomp):
        members = np.nonzero(comp == c)[0]
        Gm = G[members][:, members]
        ties = _merge_set(Gm.toarray(), members, cand, root, kernel)
        if len(members) > 1 and ties and kernel > SINGULAR:
            low = _merged_eigenvalue(Gm, members, root)
            if low < kernel and low < MERGE_GAIN * ties[0][2]:    # the merges did not help: kernels only
                root[members] = members
                ties = _merge_set(Gm.toarray(), members, cand, root, SINGULAR)
        for ia, ib, lam0 in ties:
            space.n_ties += 1
            space.tie_edges.append((int(ids[ia]), int(ids[ib]), lam0))
        if len(members) > 1:
            smallest = min(smallest, _merged_eigenvalue(Gm, members, root))
    space.n_packets = ncomp
    space.smallest = smallest
    space.rep = ids[root]


def _merge_set(Gm: FloatArray, members: IntArray, cand: IntArray, root: IntArray,
               kernel: float) -> list[tuple[int, int, float]]:
    """The merges of one set of carriers ``members`` (positions in ``ids``; ``Gm`` its Gram
    block): the candidate pairs ``cand`` are merged in order (``root`` updated) while one is
    not satisfied by every eigenvector below ``kernel``, each merge removing one kernel
    dimension.  Returns the merges ``[(a, b, smallest eigenvalue)]`` (positions)."""
    n = len(root)
    d = np.diag(Gm)
    sc = 1.0 / np.sqrt(np.where(d > 0, d, 1.0))
    lam, V = np.linalg.eigh(Gm * sc[:, None] * sc[None, :])
    Z = np.linalg.qr(V[:, lam < kernel] * sc[:, None])[0]     # orthonormal, in vertex values
    local = -np.ones(n, np.int64)
    local[members] = np.arange(len(members))
    mine = cand[(local[cand[:, 0]] >= 0) & (local[cand[:, 1]] >= 0)]
    ties = []
    for ia, ib in mine:
        if Z.shape[1] == 0:
            break
        if root[ia] == root[ib]:
            continue
        row = Z[local[ia]] - Z[local[ib]]
        if np.linalg.norm(row) <= 1e-8:
            continue                                  # every kernel vector satisfies it already
        Z = _restrict(Z, row)
        lo, hi = min(root[ia], root[ib]), max(root[ia], root[ib])
        root[root == hi] = lo
        ties.append((int(ia), int(ib), float(lam[0])))
    return ties


def _merge_candidates(ids: IntArray, edges: IntArray, r: FloatArray, cverts: IntArray) -> IntArray:
    """Pairs of carriers ``(c, 2)`` (positions in ``ids``) in the order they are tried:
    the crossed edges, nearest their middle first, then every other pair of vertices
    of an interface cell; least ids first among equals."""
    keep = (edges[:, 0] >= 0) & np.isin(edges[:, 0], ids) & np.isin(edges[:, 1], ids)
    e = np.sort(edges[keep], axis=1)
    cen = np.abs(r[keep] - 0.5)
    order = np.lexsort((e[:, 1], e[:, 0], cen))
    e, cen = e[order], cen[order]
    _, first = np.unique(e, axis=0, return_index=True)
    crossed = e[np.sort(first)]
    nv = cverts.shape[1]
    i, j = np.triu_indices(nv, k=1)
    pairs = np.sort(np.stack([cverts[:, i].ravel(), cverts[:, j].ravel()], axis=1), axis=1)
    pairs = pairs[np.isin(pairs[:, 0], ids) & np.isin(pairs[:, 1], ids)]
    pairs = np.unique(pairs, axis=0)
    out = np.concatenate([crossed, pairs]) if len(pairs) else crossed
    return np.searchsorted(ids, out.reshape(-1, 2))


def _restrict(Z: FloatArray, row: FloatArray) -> FloatArray:
    """An orthonormal basis ``(n, k - 1)`` of the vectors ``Z y`` of the span of the
    orthonormal ``Z (n, k)`` with ``row . y = 0`` (one Householder reflection)."""
    v = row / np.linalg.norm(row)
    u = v.copy()
    u[0] -= 1.0
    nu = np.linalg.norm(u)
    if nu < 1e-14:                           # v = e_0 already
        return Z[:, 1:]
    u /= nu
    return (Z - 2.0 * np.outer(Z @ u, u))[:, 1:]
