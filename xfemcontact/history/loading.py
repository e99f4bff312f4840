"""The loads of a case at any instant, applied to a :class:`~xfemcontact.model.Model`.

The model assembles its bulk system once, with the loads of the last instant.
At another instant ``t`` the imposed displacements, tractions and body forces
take their values at ``t`` (formulas of x, y, (z,) t times their FONC_MULT function,
see :class:`~xfemcontact.case.functions.TimeFormula`), and

    f0(t) = K_fc u_c(t) - F_ext(t)

(the forces of the imposed displacements minus the external forces) is rebuilt
from the element stiffness of the cells that carry an imposed component (kept
from the first call: the boundary cells only) and from the loads, the ones that
do not depend on time computed once.  The reference of Newton's relative
criterion is |f0(t)|; where it is zero (every load back to zero) the last
non-zero one is used, as code_aster does.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from xfemcontact.assembly import bulk, system
from xfemcontact.case.instant import case_at
from xfemcontact.dofs.constraints import group_nodes_everywhere
from xfemcontact.fem import elasticity
from xfemcontact.fem.coordinates import coordinates
from xfemcontact.xfem import geometry as xgeo

if TYPE_CHECKING:
    from mpi4py import MPI
    from numpy.typing import NDArray

    from xfemcontact.case.functions import TimeFormula
    from xfemcontact.case.load import Case, Traction
    from xfemcontact.mesh.raw import RawMesh
    from xfemcontact.model import Model

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]


def _uses_time(spec: Any) -> bool:
    """Whether a load (a Traction or a BodyForce, told apart by their fields) varies in time."""
    formulas: list[TimeFormula] = [spec.pressure] if getattr(spec, "pressure", None) is not None else []
    formulas += list((getattr(spec, "force", None) or {}).values())
    if hasattr(spec, "FX"):
        formulas += list(spec.components)
    return any(f.uses_time for f in formulas)


class Loading:
    """The loads of ``model.case`` at any instant (see the module documentation).

    Everything that needs the mesh groups (the nodes of the imposed displacements,
    the edges of the tractions) is gathered here, before the first solve: the
    model releases its DMPlex, groups included, when it starts solving."""

    def __init__(self, model: Model) -> None:
        self.model = model
        self.case = model.case
        mesh, geo, layout = model.mesh, model.geo, model.layout
        self._mesh, self._geo, self._layout = mesh, geo, layout
        self._lift_blocks = self._lift_matrices(model)
        self._constant: dict[int | str, FloatArray] = {}   # load index -> its (time-independent) local forces
        self.reference: float | None = None       # last non-zero |f0|
        self.t: float | None = None

        def nodes_of(groups: tuple[str, ...]) -> IntArray:
            # as every process holding them sees them (collective): a process can hold a node
            # of a face group through a cell touching the face by an edge only (3-D), and
            # would leave its copy of the node free (constraints.fixed_components does the same)
            return group_nodes_everywhere(mesh, groups)

        #: per [[dirichlet]]: its nodes (the values of a later one override an earlier one's)
        self._dirichlet = [(nodes_of(d.groups), d) for d in self.case.dirichlet]
        #: per [[traction]]: the edges (nodes (k, 3), cell, local edge) this process integrates,
        #: per group (the faces (nodes (k, 8|6), cell, local face) in 3-D)
        sides = mesh.group_faces if mesh.dim == 3 else mesh.group_edges
        self._edges = [[sides(g) for g in tr.groups] for tr in self.case.traction]
        #: per load of the load path: its label and the owned nodes of its groups
        self._path_nodes = [nodes_of(tr.groups) for tr in self.case.traction]

    @staticmethod
    def _lift_matrices(model: Model) -> list[tuple[bulk.Batch, FloatArray]]:
        """Element matrices and local dofs of the cells with an imposed displacement component."""
        mesh, geo, layout = model.mesh, model.geo, model.layout
        imposed = layout.fixed[:, :layout.dim].any(axis=1)
        touched = imposed[mesh.cell_nodes].any(axis=1)
        plain = geo.plain_cells(mesh) if geo is not None else np.arange(len(mesh.cells))
        blocks: list[tuple[bulk.Batch, FloatArray]] = []
        cells = plain[touched[plain]]
        if len(cells):
            K = bulk.PlainStiffness(mesh.element, model.D)(mesh.x[mesh.cell_nodes[cells]],
                                                           mesh.affine[cells])
            blocks.append((bulk.plain_batch(mesh, layout, cells), K))
        if geo is not None:
            enriched = geo.enriched_cells(mesh)
            cells = enriched[touched[enriched]]
            if len(cells):
                C = elasticity.tensor(model.D)
                for pts in xgeo.cell_points(mesh, geo, cells):
                    K = elasticity.stiffness(system.enriched_gradients(mesh, geo, pts), pts.w, C)
                    blocks.append((bulk.enriched_batch(mesh, layout, pts.cells), K))
        return blocks

    def _tractions(self, index: int, spec: Traction, f: FloatArray) -> None:
        """Add the forces of traction ``spec`` (the ``index``-th) on its edges to ``f``
        (what :func:`xfemcontact.assembly.system.add_tractions` does, on the edges kept)."""
        mesh, geo, layout = self._mesh, self._geo, self._layout
        for where in self._edges[index]:
            nodes = where[0]
            if len(nodes) == 0:
                continue
            if mesh.dim == 3:
                system.add_face_tractions(mesh, geo, layout, where, spec, f)
                continue
            fe = system._edge_forces_by_side(mesh, geo, nodes, mesh.x[nodes], spec)      # (k, 2, 6)
            np.add.at(f, system._edge_dofs(layout, nodes), fe.reshape(len(nodes), fe.shape[1] * fe.shape[2]))

    def _external(self, case_t: Case) -> FloatArray:
        """Local array of the external forces at the instant of ``case_t``."""
        mesh, geo, layout = self._mesh, self._geo, self._layout
        f = layout.local_array()
        # ("body", the BodyForce), then (index, the Traction) of each traction
        specs: list[tuple[int | str, Any]] = [("body", case_t.body_force)] if case_t.body_force is not None else []
        specs += [(i, tr) for i, tr in enumerate(case_t.traction)]
        for key, spec in specs:
            if key in self._constant:
                f += self._constant[key]
                continue
            part = layout.local_array()
            if isinstance(key, str):        # "body"
                system.add_body_forces(mesh, geo, layout, spec, part)
            else:
                self._tractions(key, spec, part)
            if not _uses_time(spec):
                self._constant[key] = part
            f += part
        return f

    def _imposed(self, t: float) -> FloatArray:
        """``(n, d)`` DX, DY, [DZ] imposed at instant ``t`` (as :func:`constraints.fixed_components`)."""
        x = self._mesh.x
        values = np.zeros(x.shape)
        for nodes, d in self._dirichlet:
            for c, comp in enumerate(("DX", "DY", "DZ")[:x.shape[1]]):
                if comp in d.components:
                    values[nodes, c] = d.components[comp].at(t)(**coordinates(x[nodes]))
        return values

    def apply(self, t: float) -> None:
        """Put the loads of instant ``t`` into the model: ``x_bc``, ``f0``, ``load_norm``."""
        model, layout = self.model, self._layout
        x_bc = system.bc_array(layout, layout.fixed, self._imposed(t))
        lift = layout.local_array()
        for batch, K in self._lift_blocks:
            bulk.add_lift(lift, batch, K, x_bc)
        f0 = system.local_to_global(layout, lift - self._external(case_at(self.case, t)))
        norm = f0.norm()
        if norm > 0:
            self.reference = norm
        model.set_loads(x_bc, f0, norm if norm > 0 or self.reference is None else self.reference, t)
        self.t = t

    def path(self, t: float) -> dict[str, float]:
        """The load path at ``t``: {label: mean value over the nodes of the load's groups}
        (all processes), for the plot of the loads against time."""
        from xfemcontact.errors import XfcError

        mesh = self._mesh
        mpi = self.model.comm.tompi4py()
        x = mesh.x
        out: dict[str, float] = {}

        def mean(label: str, nodes: IntArray, f: TimeFormula) -> None:
            own = nodes[mesh.node_owned[nodes]]
            try:          # tractions are evaluated at quadrature points, not at nodes
                local = (float(np.sum(f.at(t)(**coordinates(x[own])))), len(own), 1)
            except XfcError:
                local = (0.0, 0, 0)
            parts = mpi.allgather(local)
            total, count = sum(p[0] for p in parts), sum(p[1] for p in parts)
            if count and all(p[2] for p in parts):
                out[label] = float(total / count)

        for nodes, d in self._dirichlet:
            for comp, f in d.components.items():
                mean(f"{d.key}.{comp} ({', '.join(d.groups)})", nodes, f)
        for nodes, tr in zip(self._path_nodes, self.case.traction):
            items = {"PRES": tr.pressure} if tr.pressure is not None else tr.force
            assert items is not None                 # a traction gives a force or a pressure
            for comp, f in items.items():
                mean(f"{tr.key}.{comp} ({', '.join(tr.groups)})", nodes, f)
        body = self.case.body_force
        if body is not None:
            nodes = np.arange(len(x))
            for comp, f in zip(("FX", "FY", "FZ"), body.components):
                mean(f"body_force.{comp}", nodes, f)
        return out


def check_instants(case: Case, raw: RawMesh | None, comm: MPI.Comm | None = None) -> None:
    """The imposed displacements can be evaluated at the nodes of their groups at every
    instant (rank 0 checks on the input mesh ``raw``; every process raises the same
    one-line :class:`~xfemcontact.errors.FormulaError`, collective).  The last instant
    is the preflight's."""
    from xfemcontact.errors import XfcError
    from xfemcontact.preflight import _raise_shared

    outcome = None
    if comm is None or comm.rank == 0:
        assert raw is not None                   # rank 0 has the input mesh
        try:
            x = raw.points
            for d in case.dirichlet:
                nodes = np.unique(np.concatenate([raw.group_nodes(g) for g in d.groups]))
                for f in d.components.values():
                    if not f.uses_time:
                        continue
                    for t in case.instants.values[1:-1]:
                        _at_instant(f.at(t), x[nodes], t)
        except XfcError as exc:
            outcome = (type(exc).__name__, str(exc))
    _raise_shared(outcome, comm)


def _at_instant(f: TimeFormula, x: FloatArray, t: float) -> None:
    from xfemcontact.errors import FormulaError

    try:
        f(**coordinates(x))
    except FormulaError as exc:
        text = str(exc)
        raise FormulaError(text if "t=" in text else f"{text} (instant t = {t:g})") from None
