"""Checks of a case against its mesh, before any heavy work.

:func:`preflight` runs on the input mesh (the :class:`~xfemcontact.mesh.raw.RawMesh`
that rank 0 reads or generates, before it is distributed) and broadcasts its
outcome, so that every process raises the same one-line error, or gets the same
warnings: the errors it raises are *collective* (reported once, exit code 2,
no MPI_Abort).  In order:

1. the mesh can be built (read, generated, refined): :class:`MeshError` of the
   mesh reader, prefixed with the case file and ``mesh.file``;
2. the load groups exist in the mesh (:meth:`Case.check_groups`) and have the
   dimension of their load (:func:`group_dimensions`: tractions on edge groups,
   imposed displacements on edge or node groups);
3. the imposed displacements can be evaluated at the nodes of their groups
   (a formula giving NaN or inf names its key and the first bad node);
4. the level set (formula, or nodal field of the mesh file) has a finite value at
   every node; :func:`levelset_meets_domain`
   (a level set of one sign: warning, the case is solved without interface)
   and :func:`levelset_without_sign_change` (LN = 0 on a whole cell, or along
   an edge with the same side on both faces: what a crack or an interface
   ending inside the domain looks like with a normal level set alone; error);
5. :func:`rigid_body_modes`: the imposed displacements hold every body (the
   whole mesh, or each side of a ``law = "free"`` interface) against
   translations and rotation; through an interface that transmits normal forces
   only (frictionless contact, ``glissiere``), a side held by nothing else must be
   held by the normals (:func:`xfemcontact.rigid.held_through_normals`: a circular
   inclusion's rotation, a block's slide along a plane are refused);
6. :func:`interface_resolution`: how far the interface the mesh represents (the
   zero of the interpolated nodal LN) is from the zero of the level-set formula;
   beyond ``interface.max_offset`` (a fraction of the cell size) the case is
   refused, beyond :data:`OFFSET_WARNING` it is a warning (:func:`check_resolution`;
   2-D and 3-D, one code).

After the set-up, :func:`readjustment_warnings` says when the readjustment rules
had to lift many edges (an interface the mesh follows poorly).

:func:`levelset_meets_domain` also works on the nodal values of the distributed
mesh (``comm`` for the global reductions).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Iterable, cast

import numpy as np

from xfemcontact import resources
from xfemcontact.contact import laws
from xfemcontact.errors import CaseError, FormulaError, GeometryError, MeshError, XfcError
from xfemcontact.fem.coordinates import coordinates
from xfemcontact.mesh.build import build_raw_mesh
from xfemcontact.xfem.levelset import ROUNDOFF, normalised     # rule 1 of the readjustment

if TYPE_CHECKING:
    from mpi4py import MPI
    from numpy.typing import ArrayLike, NDArray

    from xfemcontact.case.load import Case, Dirichlet, MeshSpec, Traction
    from xfemcontact.contact.laws import InterfaceLaw
    from xfemcontact.fem.elements import Element
    from xfemcontact.mesh.raw import RawMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]
    #: edges shared by two cells: (first cell (k,), second cell (k,), nodes (k, 3))
    InteriorEdges = tuple[IntArray, IntArray, IntArray]
    #: what rank 0 found: ("ok", Preflight) or (error class name, message)
    Outcome = tuple[str, Any]
#: positions closer than this fraction of the mesh size are the same position
SAME_POSITION = 1e-9
#: the other sign inside a cell counts beyond this fraction of the cell's largest |LN|
#: (round-off of an interface along the cell's edge is not a closed curve)
ISLAND_ROUNDOFF = 1e-9
#: sizes of a mesh (largest side of its bounding box, m) that are accepted
MESH_EXTENT = (1e-9, 1e9)
#: represented interface farther than this fraction of the cell size from the zero of
#: the level set: a warning (interface.max_offset refuses)
OFFSET_WARNING = 0.05
#: lifted edges (readjustment rule 3) beyond which the set-up warns, in number and as a
#: fraction of the cut cells
LIFTED_WARNING = (4, 0.05)

_ERRORS = {cls.__name__: cls for cls in (CaseError, FormulaError, GeometryError, MeshError,
                                          XfcError)}


@dataclass
class Preflight:
    """What :func:`preflight` found: warnings (one line each) and whether to keep the interface."""

    warnings: list[str] = field(default_factory=list)
    interface: bool = True       # False: the level set does not meet the domain
    resolution: dict[str, Any] | None = None   # see interface_resolution (formula level sets)


# --- the whole check, collective ----------------------------------------------------------

# -- memory: a generated rectangle refused before it is built -------------------------

def check_case(case: Case, comm: MPI.Comm | None = None) -> resources.Estimate | None:
    """Check a case whose mesh is a generated rectangle from its spec alone, before the
    rectangle is built (a mesh file is checked once read: see the module docstring).
    Collective: every process computes and raises the same."""
    size = rectangle_cells(case.mesh)
    if size is None:
        return None
    nprocs = comm.size if comm is not None else 1
    return resources.check_cells(size[0], size[1], nprocs, f"{case.source}: {case.mesh.key}",
                                 nodes=box_nodes(case.mesh))


def box_nodes(spec: MeshSpec) -> int | None:
    """Nodes of a case's generated box (None for anything else): the count the DMPlex
    check uses, so that a box is judged the same before and after it is generated.
    HEXA20: vertices and mid-edge nodes; TETRA10: the vertices of the box refined once."""
    box = getattr(spec, "box", None)
    if spec.rectangle is not None or box is None:
        return None
    nx, ny, nz = (int(box[k]) for k in ("nx", "ny", "nz"))
    if box["cell"] == "TETRA10":
        return (2 * nx + 1) * (2 * ny + 1) * (2 * nz + 1)
    return ((nx + 1) * (ny + 1) * (nz + 1) + nx * (ny + 1) * (nz + 1) + (nx + 1) * ny * (nz + 1)
            + (nx + 1) * (ny + 1) * nz)


def rectangle_cells(spec: MeshSpec) -> tuple[str, int] | None:
    """``(cell_type, cells)`` of a case's generated rectangle (refinement included) or
    box, or None for a mesh file."""
    rect = spec.rectangle
    if rect is None:
        box = getattr(spec, "box", None)          # a spec written before boxes has none
        if box is None:
            return None
        per_cube = 6 if box["cell"] == "TETRA10" else 1
        return box["cell"], int(box["nx"]) * int(box["ny"]) * int(box["nz"]) * per_cube
    cell = rect.get("cell", "QUAD8")
    per_square = 2 if cell == "TRIA6" else 1
    return cell, int(rect["nx"]) * int(rect["ny"]) * per_square * 4 ** int(spec.refine or 0)


def build_mesh(case: Case, comm: MPI.Comm | None = None) -> RawMesh | None:
    """The case's input mesh on rank 0 (None elsewhere); a failure is a collective MeshError.

    Wraps :func:`xfemcontact.mesh.build.build_raw_mesh`.
    """
    rank = comm.rank if comm is not None else 0
    outcome: Outcome | None = None
    raw: RawMesh | None = None
    if rank == 0:
        try:
            raw = build_raw_mesh(case)
        except XfcError as exc:
            outcome = (type(exc).__name__, f"{case.source}: {case.mesh.key}: {exc}")
    _raise_shared(outcome, comm)
    return raw


def preflight(case: Case, raw: RawMesh | None, comm: MPI.Comm | None = None) -> Preflight:
    """Check ``case`` against its input mesh ``raw`` (rank 0; None elsewhere).

    ``comm``: an mpi4py communicator, or None when serial.  Call it on every
    process.  Raises the same :class:`XfcError` (collective) everywhere, or
    returns the same :class:`Preflight` everywhere.
    """
    rank = comm.rank if comm is not None else 0
    outcome: Outcome | None = None
    if rank == 0:
        assert raw is not None                   # rank 0 has the input mesh
        try:
            outcome = ("ok", _preflight(case, raw))
        except XfcError as exc:
            outcome = (type(exc).__name__, str(exc))
    if comm is not None and comm.size > 1:
        outcome = comm.bcast(outcome, root=0)
    assert outcome is not None                   # rank 0's
    if outcome[0] == "ok":
        return outcome[1]
    _raise_shared(outcome, None)
    raise AssertionError("unreachable: _raise_shared raised")


def _raise_shared(outcome: Outcome | None, comm: MPI.Comm | None) -> None:
    """Raise the error of ``outcome`` (rank 0's, broadcast when ``comm``) on every process."""
    if comm is not None and comm.size > 1:
        outcome = comm.bcast(outcome, root=0)
    if outcome is None:
        return
    kind, message = outcome
    raise _ERRORS.get(kind, XfcError)(message, collective=True)


def _preflight(case: Case, raw: RawMesh) -> Preflight:
    result = Preflight()
    case.check_groups(raw.group_names())
    group_dimensions(case, raw)
    size = _extent(raw.points, raw.cells)
    if not MESH_EXTENT[0] <= size <= MESH_EXTENT[1]:
        key = case.mesh.key
        raise CaseError(f"{case.source}: {key}: the mesh is {size:.3g} m across; xfemcontact "
                        f"works in SI units on meshes from {MESH_EXTENT[0]:g} to "
                        f"{MESH_EXTENT[1]:g} m across (check the unit of the coordinates)")
    used = np.flatnonzero(np.bincount(raw.cells.ravel(), minlength=len(raw.points)))  # sorted
    x = raw.points
    for bc in case.dirichlet:
        nodes = _group_nodes(raw, bc.groups)
        for name, formula in bc.components.items():
            formula(**coordinates(x[nodes]))              # FormulaError names key and node
    if raw.dim == 3:
        return _preflight_3d(case, raw, used, result)
    interior = _interior_edges(raw.cells, raw.n_vertices_per_cell)
    phi = None
    itf = case.interface
    if itf is not None:
        if itf.level_set is not None:
            key = "interface.level_set"
            values = itf.level_set(x=x[used, 0], y=x[used, 1])
        else:
            key = "interface.level_set_field"
            values = _field_values(case, raw, itf.level_set_field)[used]
            bad = ~np.isfinite(values)
            if bad.any():
                n = int(used[np.argmax(bad)])
                raise MeshError(f"{case.source}: {key}: '{itf.level_set_field}' is not finite "
                                f"at node {n} ({x[n, 0]:.6g}, {x[n, 1]:.6g}) of {raw.source}")
        phi = np.zeros(len(x))
        phi[used] = normalised(values)          # a power of two: exact, no over/underflow
        phi = _roundoff(raw.cells, phi)
        island = closed_curve_in_cell(raw, phi, source=case.source, key=key)
        if island:
            raise GeometryError(island)
        given = np.where(phi[used] == 0, 0.0, values)        # the values as given, in messages
        warning = levelset_meets_domain(given, x[used], source=case.source, key=key)
        if warning:
            result.warnings.append(warning)
            result.interface = False
            phi = None
        else:
            problem = levelset_without_sign_change(raw.cells, raw.n_vertices_per_cell, phi, x,
                                                   source=case.source, key=key, interior=interior)
            if problem:
                raise GeometryError(problem)
        check_resolution(case, raw, phi, result)
    law = laws.get(itf.law) if itf is not None and phi is not None else None
    problem = rigid_body_modes(case, raw, phi, law, interior=interior) or \
        _held_through_normals(case, raw, phi, law, result)
    if problem:
        raise CaseError(problem)
    return result


def _held_through_normals(case: Case, raw: RawMesh, phi: FloatArray | None,
                          law: InterfaceLaw | None, result: Preflight) -> str | None:
    """:func:`xfemcontact.rigid.held_through_normals` when the interface transmits normal
    forces only (2-D and 3-D): its error, its warnings added to ``result``."""
    from xfemcontact import rigid

    words = law.normal_only(case) if law is not None and phi is not None else None
    if not words or phi is None:
        return None
    error, warnings = rigid.held_through_normals(case, raw, phi, words)
    result.warnings.extend(warnings)
    return error


def _preflight_3d(case: Case, raw: RawMesh, used: IntArray, result: Preflight) -> Preflight:
    """What :func:`_preflight` checks of a 3-D mesh after the groups, the extent and the
    imposed displacements: the level set (finite, meets the domain, no cell with LN = 0 at
    every node, what 3-D contact does not do refused, the interface resolution as in 2-D)
    and the rigid-body motions (:mod:`xfemcontact.rigid`, each side a body for ``free``)."""
    from xfemcontact import rigid

    itf = case.interface
    phi: FloatArray | None = None
    if itf is not None and case.contact.algo_lagr == "STABLE":
        raise CaseError(f"{case.source}: contact.algo_lagr: STABLE is a 2-D multiplier space; in 3-D "
                        "use AUTO (the default) or NON")
    if itf is not None:
        x = raw.points
        if itf.level_set is not None:
            key = "interface.level_set"
            values = itf.level_set(**coordinates(x[used]))
        else:
            key = "interface.level_set_field"
            values = _field_values(case, raw, itf.level_set_field)[used]
        phi = np.zeros(len(x))
        phi[used] = normalised(np.where(np.isfinite(values), values, np.nan))
        phi = _roundoff(raw.cells, phi)
        if np.isnan(phi[used]).any():
            raise MeshError(f"{case.source}: {key}: the level set is not finite at some nodes of "
                            f"{raw.source}")
        warning = levelset_meets_domain(np.where(phi[used] == 0, 0.0, values), None,
                                        source=case.source, key=key)
        if warning:
            result.warnings.append(warning)
            result.interface = False
            phi = None
        else:
            flat = np.flatnonzero(~(phi[raw.cells] != 0).any(axis=1))
            if len(flat):
                ctr = x[raw.cells[flat[0]]].mean(axis=0)
                raise GeometryError(f"{case.source}: {key}: LN = 0 at every node of cell {flat[0]} near "
                                    f"({ctr[0]:.6g}, {ctr[1]:.6g}, {ctr[2]:.6g}): the interface must be "
                                    f"a surface with LN < 0 on one side and LN > 0 on the other")
        check_resolution(case, raw, phi, result)
    law = laws.get(itf.law) if itf is not None and phi is not None else None
    problem = rigid.check(case, raw, phi if law is not None and law.separate_bodies else None) or \
        _held_through_normals(case, raw, phi, law, result)
    if problem:
        raise CaseError(problem)
    return result


# --- groups ------------------------------------------------------------------------------

def group_dimensions(case: Case, raw: RawMesh) -> None:
    """CaseError when a load names a group of the wrong dimension: tractions act on edge
    groups (face groups in 3-D), imposed displacements on face, edge or node groups (not
    on cell groups)."""
    mesh = raw.source if case.mesh.file is not None else case.mesh.name
    side = "face" if raw.dim == 3 else "edge"

    def kinds(name: str) -> list[str]:
        return [kind for kind, groups in (("face", raw.face_groups), ("edge", raw.edge_groups),
                                          ("node", raw.node_groups), ("cell", raw.cell_groups))
                if name in groups]

    def listed(kind: str) -> str:
        names = sorted({"face": raw.face_groups, "edge": raw.edge_groups, "node": raw.node_groups,
                        "cell": raw.cell_groups}[kind])
        return ", ".join(names[:20]) + (", ..." if len(names) > 20 else "") or "none"

    load: Traction | Dirichlet
    for load in case.traction:
        for group in load.groups:
            found = kinds(group)
            if side not in found:
                what = "FORCE_FACE, PRES_REP" if side == "face" else "FORCE_CONTOUR, PRES_REP"
                raise CaseError(f"{case.source}: {load.key}.group: '{group}' is a {found[0]} group "
                                f"of {mesh}; tractions ({what}) act on {side} groups "
                                f"({side} groups: {listed(side)})")
    for load in case.dirichlet:
        for group in load.groups:
            found = kinds(group)
            if found == ["cell"]:
                faces = f"face groups: {listed('face')}; " if raw.dim == 3 else ""
                raise CaseError(f"{case.source}: {load.key}.group: '{group}' is a cell group of "
                                f"{mesh}; imposed displacements act on {'face, ' if faces else ''}"
                                f"edge or node groups ({faces}edge groups: {listed('edge')}; node "
                                f"groups: {listed('node')})")


def _field_values(case: Case, raw: RawMesh, name: str | None) -> FloatArray:
    """Nodal field ``name`` of the mesh file (the level set), or a MeshError listing them."""
    fields = getattr(raw, "point_data", None) or {}
    if name not in fields:
        names = ", ".join(sorted(fields)) or "none"
        raise MeshError(f"{case.source}: interface.level_set_field: no nodal field '{name}' in "
                        f"{raw.source} (nodal fields: {names})")
    return np.asarray(fields[name], dtype=float).reshape(-1)


def _group_nodes(raw: RawMesh, groups: Iterable[str]) -> IntArray:
    return np.unique(np.concatenate([raw.group_nodes(g) for g in groups]))


def _roundoff(cells: IntArray, phi: FloatArray) -> FloatArray:
    """``phi`` with |LN| <= ROUNDOFF * (largest |LN| of the cells holding the node) set to 0."""
    from xfemcontact.xfem.levelset import cell_max_at_nodes

    scale = cell_max_at_nodes(cells, np.abs(phi))
    out = phi.copy()
    out[np.abs(phi) <= ROUNDOFF * scale] = 0.0
    return out


# --- the level set ------------------------------------------------------------------------

def levelset_meets_domain(phi: ArrayLike, x: FloatArray | None = None, comm: MPI.Comm | None = None,
                          source: str = "<case>", key: str = "interface.level_set") -> str | None:
    """A warning (one line) when LN does not take both signs on the mesh, else None.

    ``phi``: LN at the nodes (of this process when ``comm``, an mpi4py
    communicator, is given: the extremes are then reduced over all processes);
    ``x`` ``(n, 2)``: their coordinates, to say where LN touches 0.  Values
    that must count as 0 should already be 0 (readjustment rule 1).  Without
    a negative or without a positive value there is no interface: the case
    can be solved as if it had none.
    """
    phi = np.asarray(phi, dtype=float)
    low = float(phi.min()) if len(phi) else np.inf
    high = float(phi.max()) if len(phi) else -np.inf
    if comm is not None and comm.size > 1:
        from mpi4py import MPI

        low = comm.allreduce(low, op=MPI.MIN)
        high = comm.allreduce(high, op=MPI.MAX)
    if low < 0 < high or not np.isfinite(low) or not np.isfinite(high):
        return None
    prefix = f"{source}: {key}: "
    if low > 0 or high < 0:
        sign = ">" if low > 0 else "<"
        return (prefix + f"the interface does not meet the domain (LN {sign} 0 at every node, "
                f"from {low:.4g} to {high:.4g}): solving without interface")
    sign = ">=" if high > 0 else "<="
    zero = np.flatnonzero(phi == 0)
    near = ""
    if x is not None and len(zero) and (comm is None or comm.size == 1):
        near = f" at {len(zero)} node(s), near ({x[zero[0], 0]:.6g}, {x[zero[0], 1]:.6g})"
    return (prefix + f"the interface only touches the domain (LN {sign} 0 at every node, "
            f"LN = 0{near}; no side with LN {'<' if high > 0 else '>'} 0): "
            f"solving without interface")


def closed_curve_in_cell(raw: RawMesh, phi: FloatArray, source: str = "<case>",
                         key: str = "interface.level_set") -> str | None:
    """An error message when the interpolated LN changes sign inside a cell whose nodes
    all have one sign (a closed interface smaller than the cell, which the cut cannot
    follow), else None.  ``phi``: nodal LN (normalised, round-off set to 0)."""
    from xfemcontact.fem.elements import element

    cells = raw.cells
    pc = phi[cells]
    lo, hi = pc.min(axis=1), pc.max(axis=1)
    one_sign = (lo >= 0) | (hi <= 0)
    near = one_sign & (np.abs(pc).min(axis=1) <= 2.0 * (hi - lo))
    cand = np.flatnonzero(near)
    if len(cand) == 0:
        return None
    el = element(raw.cell_type)
    N = el.shape(_sample_points(el))
    vals = pc[cand] @ N.T                                    # (k, m)
    side = np.where(hi[cand] > 0, 1.0, -1.0)
    scale = np.abs(pc[cand]).max(axis=1)
    wrong = np.any(vals * side[:, None] < -ISLAND_ROUNDOFF * scale[:, None], axis=1)
    if not wrong.any():
        return None
    c = int(cand[np.argmax(wrong)])
    ctr = raw.points[cells[c]].mean(axis=0)
    sign = ">" if side[np.argmax(wrong)] > 0 else "<"
    return (f"{source}: {key}: the interface makes a closed curve inside cell {c} near "
            f"({ctr[0]:.6g}, {ctr[1]:.6g}), smaller than the cell (LN {sign} 0 at its nodes, "
            f"the other sign inside): refine the mesh there")


def levelset_without_sign_change(cells: IntArray, nv: int, phi: FloatArray, x: FloatArray,
                                 source: str = "<case>", key: str = "interface.level_set",
                                 interior: InteriorEdges | None = None) -> str | None:
    """An error message when LN is 0 where it does not separate two sides, else None.

    ``cells`` ``(nc, nn)`` node indices (vertices first, then the mid-edge node of
    edge ``k`` = vertices ``k``, ``k+1``), ``nv`` vertices per cell, ``phi`` LN
    at the nodes (round-off already set to 0), ``x`` the node coordinates.
    Refused: a cell whose nodes are all 0, and an interior edge whose three
    nodes are 0 while the two cells on it are on the same side -- a normal
    level set alone cannot describe an interface that ends inside the domain
    (a crack): its zero line would have to stop changing sign somewhere.
    ``interior``: :func:`_interior_edges` of ``cells`` if already known.
    """
    pc = phi[cells]
    pos, neg = (pc > 0).any(axis=1), (pc < 0).any(axis=1)
    flat = ~pos & ~neg
    prefix = f"{source}: {key}: "
    if flat.any():
        c = int(np.flatnonzero(flat)[0])
        ctr = x[cells[c]].mean(axis=0)
        return (prefix + f"LN = 0 at every node of cell {c} near ({ctr[0]:.6g}, {ctr[1]:.6g}): "
                         f"the interface must be a curve with LN < 0 on one side and LN > 0 on "
                         f"the other")
    c1, c2, enodes = _interior_edges(cells, nv) if interior is None else interior
    if len(c1) == 0:
        return None
    side = np.where(pos & neg, 0, np.where(pos, 1, -1))
    zero = np.all(phi[enodes] == 0, axis=1)
    same = zero & (side[c1] == side[c2]) & (side[c1] != 0)
    if not same.any():
        return None
    k = int(np.flatnonzero(same)[0])
    mid = x[enodes[k, 2]]
    count = int(same.sum())
    s = "<" if side[c1[k]] < 0 else ">"
    return (prefix + f"LN = 0 along {count} edge(s) without changing sign (LN {s} 0 on both "
                     f"sides), first near ({mid[0]:.6g}, {mid[1]:.6g}): an interface must "
                     f"separate LN < 0 from LN > 0 and cross the whole domain or close on "
                     f"itself (cracks and interfaces ending inside the domain are not "
                     f"supported)")


def _cell_edges(cells: IntArray, nv: int) -> IntArray:
    """``(nc * nv, 3)`` nodes (a, b, mid) of every cell edge, cell by cell."""
    k = np.arange(nv)
    return np.stack([cells[:, k], cells[:, (k + 1) % nv], cells[:, nv + k]], axis=-1).reshape(-1, 3)


def _interior_edges(cells: IntArray, nv: int) -> InteriorEdges:
    """Edges shared by two cells: ``(c1, c2, nodes (k, 3))``, found by their mid-node."""
    edges = _cell_edges(cells, nv)
    owner = np.repeat(np.arange(len(cells)), nv)
    order = np.argsort(edges[:, 2], kind="stable")
    mids = edges[order, 2]
    pair = np.flatnonzero(mids[1:] == mids[:-1])
    a, b = order[pair], order[pair + 1]
    return owner[a], owner[b], edges[a]


# --- rigid-body modes ---------------------------------------------------------------------

def rigid_body_modes(case: Case, raw: RawMesh, phi: FloatArray | None = None,
                     law: InterfaceLaw | None = None,
                     interior: InteriorEdges | None = None) -> str | None:
    """A one-line error message when a rigid-body motion is left free, else None.

    Bodies: the connected parts of the mesh (cells sharing an edge); with an
    interface whose ``law`` (an :class:`~xfemcontact.contact.laws.InterfaceLaw`)
    has ``separate_bodies`` (``free``; and ``phi``, LN at the nodes of ``raw``),
    each side of it is a separate body.  Other laws connect the sides ("contact"
    too, although it transmits compression only: a body held by contact alone is
    accepted; if the contact opens, the solve fails and says so).

    A node of a Dirichlet group holds the body of its side (LN >= 0: the +
    side); where the group's edge reaches the interface, or for a node group,
    both sides (their Heaviside dofs are imposed too, see
    :mod:`xfemcontact.dofs.constraints`).  A body is held when DX is imposed
    somewhere, DY somewhere, and the rotation is blocked: DX at two different
    y or DY at two different x.  ``interior``: :func:`_interior_edges` of the
    cells if already known.
    """
    cells, nv, x = raw.cells, raw.n_vertices_per_cell, raw.points
    nc = len(cells)
    separate = law is not None and law.separate_bodies and phi is not None
    phi = cast("FloatArray", phi)       # read only where separate, which needs it
    if separate:
        pc = phi[cells]
        has = np.stack([(pc < 0).any(axis=1), (pc > 0).any(axis=1)], axis=1)   # [-, +]
        has[~has.any(axis=1), 1] = True
    else:
        has = np.zeros((nc, 2), bool)
        has[:, 1] = True
    piece = np.arange(2 * nc).reshape(nc, 2)          # piece (cell, side): 2 c + (side > 0)
    c1, c2, enodes = _interior_edges(cells, nv) if interior is None else interior
    links = []
    for s in (0, 1):
        ok = has[c1, s] & has[c2, s]
        if separate:
            e = phi[enodes]
            ok &= (e < 0).any(axis=1) if s == 0 else (e > 0).any(axis=1)
        links.append((piece[c1[ok], s], piece[c2[ok], s]))
    label = _components(2 * nc, links)
    exists = has.ravel()

    # constrained pieces per component: for DX the y, for DY the x of the held nodes
    incid = _node_cells(cells, len(x))
    lo = {c: np.full(2 * nc, np.inf) for c in ("DX", "DY")}
    hi = {c: np.full(2 * nc, -np.inf) for c in ("DX", "DY")}
    groups: dict[str, dict[int, set[str]]] = {c: {} for c in ("DX", "DY")}
    for bc in case.dirichlet:
        nodes = _group_nodes(raw, bc.groups)
        both = np.zeros(len(x), bool)
        if separate:
            both[_interface_nodes(raw, bc.groups, phi)] = True
        node_side = (phi >= 0).astype(int) if separate else np.ones(len(x), int)
        cell_of, node_of = _incident(incid, nodes)
        sides = [node_side[node_of]]
        if separate:
            sides.append(np.where(both[node_of], 1 - node_side[node_of], -1))
        held_pieces, held_nodes = [], []
        for side in sides:
            keep = side >= 0
            p = piece[cell_of[keep], side[keep]]
            live = exists[p]
            held_pieces.append(p[live])
            held_nodes.append(node_of[keep][live])
        body_of = label[np.concatenate(held_pieces)]
        held = np.concatenate(held_nodes)
        for comp in bc.components:
            # a rigid motion (a - theta y, b + theta x): DX fixes a - theta y, DY b + theta x
            at = x[held, 1] if comp == "DX" else x[held, 0]
            np.minimum.at(lo[comp], body_of, at)
            np.maximum.at(hi[comp], body_of, at)
            for k in np.unique(body_of):
                groups[comp].setdefault(int(k), set()).update(bc.groups)

    size = _extent(x, cells) if nc else 1.0
    tol = SAME_POSITION * max(size, 1e-300)
    bodies = np.unique(label[exists])
    for body in bodies:
        problem = _free_motions(body, lo, hi, groups, tol)
        if problem:
            return f"{case.source}: dirichlet: rigid-body motion not prevented" + \
                _which_body(body, label, exists, cells, x, len(bodies), separate) + \
                f": {problem}"
    return None


def _components(n: int, links: list[tuple[IntArray, IntArray]]) -> IntArray:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    a = np.concatenate([l[0] for l in links]) if links else np.zeros(0, int)
    b = np.concatenate([l[1] for l in links]) if links else np.zeros(0, int)
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n)).tocsr()
    return connected_components(graph, directed=False)[1]


def _node_cells(cells: IntArray, n: int) -> tuple[IntArray, IntArray]:
    """CSR node -> cells incidence: ``(indptr, cell indices)``."""
    node = cells.ravel()
    order = np.argsort(node, kind="stable")
    cell = (order // cells.shape[1])
    indptr = np.zeros(n + 1, dtype=np.int64)
    indptr[1:] = np.cumsum(np.bincount(node, minlength=n))
    return indptr, cell


def _incident(incid: tuple[IntArray, IntArray], nodes: IntArray) -> tuple[IntArray, IntArray]:
    """``(cells, nodes)``: every (cell, node) pair with ``node`` in ``nodes``."""
    indptr, cell = incid
    start, stop = indptr[nodes], indptr[nodes + 1]
    count = stop - start
    node_of = np.repeat(nodes, count)
    offset = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    return cell[np.repeat(start, count) + offset], node_of


def _interface_nodes(raw: RawMesh, groups: Iterable[str], phi: FloatArray) -> IntArray:
    """Nodes of ``groups`` that hold both sides: node groups, edges reaching the interface."""
    out = []
    for g in groups:
        if g in raw.node_groups:
            out.append(np.asarray(raw.node_groups[g]).ravel())
        if g in raw.edge_groups:
            e = np.asarray(raw.edge_groups[g]).reshape(-1, 3)
            p = phi[e]
            touch = ~(np.all(p > 0, axis=1) | np.all(p < 0, axis=1))
            out.append(e[touch].ravel())
    return np.concatenate(out).astype(np.int64) if out else np.zeros(0, np.int64)


def _free_motions(body: int, lo: dict[str, FloatArray], hi: dict[str, FloatArray],
                  groups: dict[str, dict[int, set[str]]], tol: float) -> str | None:
    """What is free for component ``body``, in words, or None."""
    has = {c: np.isfinite(lo[c][body]) for c in ("DX", "DY")}
    spread = {c: has[c] and hi[c][body] - lo[c][body] > tol for c in ("DX", "DY")}
    missing = [c for c in ("DX", "DY") if not has[c]]
    rotation = not (spread["DX"] or spread["DY"])
    if missing:
        axes = " and ".join(c[1].lower() for c in missing)
        what = f"translation{'s' if len(missing) > 1 else ''} in {axes}"
        if rotation:
            what += " and rotation are free"
        else:
            what += " is free" if len(missing) == 1 else " are free"
        fix = " and ".join(missing)
        where = ""
        if rotation and len(missing) == 1:
            other = "DY" if missing[0] == "DX" else "DX"
            where = f" (at a point where {other} is not imposed, or at two points)"
        return f"nothing imposes {' or '.join(missing)} ({what}): impose {fix} somewhere{where}"
    if rotation:
        y0, x0 = lo["DX"][body], lo["DY"][body]
        dx = ", ".join(sorted(groups["DX"].get(int(body), ())))
        dy = ", ".join(sorted(groups["DY"].get(int(body), ())))
        return (f"rotation is free: DX is imposed only at y = {y0:.6g} ({dx}) and DY only at "
                f"x = {x0:.6g} ({dy}); impose DX at another y, or DY at another x")
    return None


def _which_body(body: int, label: IntArray, exists: BoolArray, cells: IntArray, x: FloatArray,
                n_bodies: int, separate: bool) -> str:
    if n_bodies == 1:
        return ""
    mine = np.flatnonzero((label == body) & exists)
    cell = mine // 2
    ctr = x[cells[cell]].mean(axis=(0, 1))
    where = f"{len(cell)} cell(s) around ({ctr[0]:.4g}, {ctr[1]:.4g})"
    if separate:
        side = "LN > 0" if mine[0] % 2 else "LN < 0"
        return (f" for the part on the {side} side of the interface ({where}; with "
                f"law = \"free\" each side is a separate body)")
    return f" for the part of the mesh made of {where} (it shares no edge with the rest)"


def _extent(x: FloatArray, cells: IntArray) -> float:
    """Largest side of the bounding box of the nodes that cells use, m."""
    used = np.zeros(len(x), bool)
    used[cells.ravel()] = True
    xu = x[used]
    return float(max(np.ptp(xu[:, c]) for c in range(xu.shape[1])))


# --- how well the mesh represents the interface ---------------------------------------------

def check_resolution(case: Case, raw: RawMesh, phi: FloatArray | None, result: Preflight) -> None:
    """:func:`interface_resolution` of a ``level_set`` formula into ``result`` (2-D and 3-D):
    its outcome (``result.resolution``, results.json ``interface_resolution``) and the
    warning beyond :data:`OFFSET_WARNING`; a :class:`GeometryError` beyond
    ``interface.max_offset``.  ``phi``: the nodal LN, None when it takes one sign on the
    nodes (the warning then replaces "does not meet the domain")."""
    itf = case.interface
    if itf is None or itf.level_set is None:
        return
    result.resolution = interface_resolution(case, raw, phi)
    message = _resolution_message(case, result.resolution)
    if message is not None and result.resolution is not None and result.resolution["refused"]:
        raise GeometryError(message)
    if message is not None and phi is None:
        # it meets the domain, but between the nodes: said instead of "does not meet"
        result.warnings = [message + ": solving without interface"]
    elif message is not None:
        result.warnings.append(message)


def _sample_points(el: Element, k: int = 6) -> FloatArray:
    """Reference points ``(m, dim)`` of a k-interval grid of the cell, corners, edges and
    faces included: on simplices (TRIA6, TETRA10) the grid points with coordinates summing
    to at most 1 (28 / 84 points for k = 6), on quadrangles and hexahedra the whole
    (k + 1)^dim grid of [-1, 1]^dim (49 / 343 points).  First coordinate slowest."""
    t = np.linspace(0.0, 1.0, k + 1)
    index = np.stack(np.meshgrid(*[np.arange(k + 1)] * el.dim, indexing="ij"), axis=-1).reshape(-1, el.dim)
    if el.nv == el.dim + 1:                                     # a simplex
        return t[index[index.sum(axis=1) <= k]]
    return (2.0 * t - 1.0)[index]


#: sample points a batch of :func:`interface_resolution` (4096 QUAD8 cells of 49 points)
SAMPLES_PER_BATCH = 4096 * 49


def interface_resolution(case: Case, raw: RawMesh, phi: FloatArray | None) -> dict[str, Any] | None:
    """How far the interface the mesh represents is from the zero of the level-set formula
    (2-D and 3-D: the same rule).

    On the cells near the interface (nodal LN of both signs, or smaller than twice its
    spread in the cell), LN is sampled on a grid of each cell (:func:`_sample_points`): the
    formula ``f`` and the interpolant ``p`` of its nodal values.  Where their signs differ,
    a point lies between the two zero sets (lines in 2-D, surfaces in 3-D), which are then
    at least ``|f| / |grad f| + |p| / |grad p|`` apart there (each distance capped at the
    cell size h, the largest distance between its vertices; grad f by central differences
    of 1e-7 h).  Returns a dict: the largest such offset ``offset_h`` (a fraction of the
    cell's h) and ``offset_m`` (m), where (``at``: d coordinates, ``cell``), whether the
    nodal values of that cell have both signs (``seen``), the cells sampled, and
    ``refused`` (``offset_h`` above ``interface.max_offset``); None where the formula is
    not finite at a sample point.  ``phi``: the nodal LN (None when it does not take both
    signs on the nodes).
    """
    from xfemcontact.fem.elements import element

    itf = case.interface
    assert itf is not None and itf.level_set is not None     # a level-set formula
    el = element(raw.cell_type)
    cells, x = raw.cells, raw.points
    used = np.unique(cells)
    values = np.zeros(len(x))
    values[used] = itf.level_set(**coordinates(x[used]))
    # exact (a power of two): no overflow, no underflow; the exponent bounded so that a
    # formula whose values are all subnormal (a fuzzed one: 1e-320) is not scaled to inf
    exponent = int(np.clip(np.frexp(np.abs(values).max())[1], -1000, 1000)) if values.any() else 0
    scale = float(np.ldexp(1.0, -exponent))
    values *= scale

    formula = itf.level_set

    def level_set(points: FloatArray) -> FloatArray:
        return formula(**coordinates(points)) * scale

    pc = values[cells]
    lo, hi = pc.min(axis=1), pc.max(axis=1)
    near = ((lo < 0) & (hi > 0)) | (np.abs(pc).min(axis=1) <= 2.0 * (hi - lo))
    cand = np.flatnonzero(near)
    out: dict[str, Any] = {"offset_h": 0.0, "offset_m": 0.0, "at": None, "cell": None,
                           "seen": True, "sampled_cells": int(len(cand)),
                           "max_offset": itf.max_offset, "refused": False}
    if len(cand) == 0:
        return out
    xi = _sample_points(el)
    shapes = (xi, el.shape(xi), el.dshape(xi))
    batch = max(1, SAMPLES_PER_BATCH // len(xi))
    best: tuple[float, tuple[int, float, FloatArray] | None] = (0.0, None)
    for start in range(0, len(cand), batch):
        try:
            found = _batch_offset(el, x[cells[cand[start:start + batch]]], pc[cand[start:start + batch]],
                                  shapes, level_set)
        except XfcError:               # not finite between the nodes: cannot tell here
            return None
        if found is not None and found[0] > best[0]:
            offset, i, metres, at = found
            best = (offset, (int(cand[start + i]), metres, at))
    if best[1] is not None:
        cell, metres, at = best[1]
        out.update(offset_h=best[0], offset_m=metres, at=[float(a) for a in at], cell=cell,
                   seen=bool(lo[cell] < 0 < hi[cell] or phi is not None and
                             (phi[cells[cell]] == 0).any()))
        out["refused"] = best[0] > itf.max_offset
    return out


def _batch_offset(el: Element, xc: FloatArray, pc: FloatArray, shapes: tuple[FloatArray, FloatArray, FloatArray],
                  level_set: Any) -> tuple[float, int, float, FloatArray] | None:
    """The largest offset of :func:`interface_resolution` over a batch of cells: ``xc (b,
    nn, d)`` their nodes (m), ``pc (b, nn)`` the nodal LN, ``shapes`` the sample points
    ``xi (m, d)`` with the shape functions ``(m, nn)`` and their reference gradients
    ``(m, nn, d)`` there, ``level_set`` the formula of points ``(..., d)``.  Returns
    (offset / h, the cell's row in the batch, offset (m), the point ``(d,)``), None where
    the signs agree everywhere; raises the formula's XfcError where it is not finite."""
    from xfemcontact.fem.elements import physical_gradients

    xi, N, dN = shapes
    pts = np.matmul(N, xc)                                   # (b, m, d)
    p = pc @ N.T                                             # (b, m)
    f = level_set(pts)
    wrong = (np.sign(f) * np.sign(p) < 0)
    if not wrong.any():
        return None
    b, m = np.nonzero(wrong)
    h = np.linalg.norm(xc[:, :el.nv, None] - xc[:, None, :el.nv], axis=-1).max(axis=(1, 2))
    rows, inverse = np.unique(b, return_inverse=True)       # the Jacobians of these cells only
    J = el.jacobians(xc[rows], xi)[inverse, m]               # (k, d, d)
    grads, _ = physical_gradients(dN[m], J)                  # (k, nn, d)
    gp = np.einsum("ka,kai->ki", pc[b], grads)
    here = pts[b, m]
    step = 1e-7 * h[b]
    unit = np.eye(xc.shape[2])
    gf = np.stack([(level_set(here + step[:, None] * e) - level_set(here - step[:, None] * e)) / (2 * step)
                   for e in unit], -1)
    with np.errstate(all="ignore"):
        df = np.abs(f[b, m]) / np.linalg.norm(gf, axis=1)
        dp = np.abs(p[b, m]) / np.linalg.norm(gp, axis=1)
    hb = h[b]
    df = np.where(np.isfinite(df), np.minimum(df, hb), hb)
    dp = np.where(np.isfinite(dp), np.minimum(dp, hb), hb)
    offset = (df + dp) / hb
    i = int(np.argmax(offset))
    return float(offset[i]), int(b[i]), float(offset[i] * hb[i]), here[i]


def _resolution_message(case: Case, r: dict[str, Any] | None) -> str | None:
    """The warning or refusal of :func:`interface_resolution`'s outcome ``r``, or None."""
    if r is None or r["offset_h"] <= OFFSET_WARNING:
        return None
    at = "(" + ", ".join(f"{a:.4g}" for a in r["at"]) + ")"
    prefix = f"{case.source}: interface.level_set: "
    if not r["seen"]:
        closed = "a closed surface" if len(r["at"]) == 3 else "a closed curve"
        what = (f"the level set changes sign inside cell {r['cell']} near {at} but not at its "
                f"nodes: the mesh does not see the interface there ({closed} or a fold "
                f"smaller than the cell?)")
    else:
        what = (f"the interface the mesh represents is up to {r['offset_h']:.2g} h "
                f"({r['offset_m']:.3g} m) from the zero of the level set, near {at}")
    if r["refused"]:
        return (prefix + what + f"; the level set varies faster than the cells can follow: refine "
                f"the mesh there, or accept it with interface.max_offset = "
                f"{max(r['offset_h'], 0.01) * 1.01:.2g} (now {r['max_offset']:g})")
    return prefix + what + "; refine the mesh there for a closer interface"


def readjustment_warnings(case: Case, model: Any) -> list[str]:
    """Warnings (one line each, every process the same) when the readjustment rules
    lifted many edges: the level set crosses edges twice, so the interface was moved to
    cross them once (collective).  ``model``: the set-up
    :class:`~xfemcontact.model.Model` (not imported: it imports this module)."""
    geo = model.geo
    if geo is None:
        return []
    mpi = model.comm.tompi4py()
    r = geo.readjustment
    lifted = mpi.allreduce(int(r.lifted_edges))
    pushed = mpi.allreduce(int(r.pushed_off))
    cut = mpi.allreduce(len(geo.cut_cells))
    many, fraction = LIFTED_WARNING
    if lifted <= many or lifted <= fraction * max(cut, 1):
        return []
    itf = case.interface
    assert itf is not None                  # the geometry comes from the interface
    key = "interface.level_set" if itf.level_set is not None else "interface.level_set_field"
    return [f"{case.source}: {key}: the level set crosses {lifted} cell edge(s) twice (of "
            f"{cut} cut cells; {pushed} pushed off): the interface was moved there to cross "
            f"each edge once; the mesh is too coarse for this interface (refine it)"]
