"""Degrees of freedom as a PetscSection on the DMPlex points.

Four fields, each on the points (vertices and edges) that carry the node:

==========  ===================  =======================================================
field       components           carried by
==========  ===================  =======================================================
0 u         DX, DY (DZ in 3-D)   every node
1 h         H1X, H1Y (H1Z)       Heaviside-enriched nodes
2 LAGS_C    contact pressure     representative vertices of the multiplier space
3 LAGS_F1   friction             the same vertices (3-D: LAGS_F1, LAGS_F2, two
                                 tangential components)
==========  ===================  =======================================================

Within a point, dofs are ordered field by field, so node ``i``'s local dofs are
``off[i] + (DX, DY, [DZ], [H1X, H1Y, [H1Z]], [LAGS_C, LAGS_F1, [LAGS_F2]])``; the PetscSection
itself has one field (the kinds are told apart by these index arrays only).  The
dimension ``d`` (2 or 3) is the mesh's.
Imposed components (Dirichlet conditions, Heaviside dofs forced to zero) are
section constraints: they are in the local vectors and out of the global system,
so every KSP/PC sees the reduced, symmetric operator.

Index arrays use -1 for "absent"; global arrays also use -1 for constrained
dofs (PETSc ignores negative indices in MatSetValues/VecSetValues).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from xfemcontact._petsc import PETSc

if TYPE_CHECKING:
    from numpy.typing import ArrayLike, NDArray

    from xfemcontact.mesh.plex import LocalMesh

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    BoolArray = NDArray[np.bool_]

FIELDS = ("u", "h", "LAGS_C", "LAGS_F1")
COMPONENTS = {"u": ("DX", "DY"), "h": ("H1X", "H1Y"), "LAGS_C": ("LAGS_C",), "LAGS_F1": ("LAGS_F1",)}
#: the displacement components of 3-D meshes
COMPONENTS_3D = {"u": ("DX", "DY", "DZ"), "h": ("H1X", "H1Y", "H1Z")}


class DofLayout:
    """The dofs of one process's nodes and their global numbers.

    Parameters
    ----------
    mesh : LocalMesh
    enriched : (n,) bool
        Nodes carrying Heaviside dofs.
    multiplier : (n,) bool
        Vertices carrying LAGS_C and LAGS_F1 (the representatives of the
        multiplier space).
    fixed : (n, 2 d) bool
        Constrained components (DX, DY, [DZ], H1X, H1Y, [H1Z]); H components only
        where enriched.

    All three must agree on points shared by several processes.
    """

    def __init__(self, mesh: LocalMesh, enriched: ArrayLike, multiplier: ArrayLike,
                 fixed: ArrayLike) -> None:
        n = len(mesh.x)
        self.mesh = mesh
        #: space dimension: displacement components per node
        self.dim: int = mesh.dim
        d = self.dim
        self.enriched: BoolArray = np.asarray(enriched, bool)
        self.multiplier: BoolArray = np.asarray(multiplier, bool)
        self.fixed: BoolArray = np.asarray(fixed, bool) & np.c_[np.ones((n, d), bool),
                                                                np.repeat(self.enriched[:, None], d, axis=1)]
        self._counts: dict[str, int] | None = None    # free dofs by kind, summed over processes on first use
        self._scatter: tuple[PETSc.Scatter, PETSc.Vec] | None = None     # see scatter
        section = self._build_section()
        dm = mesh.plex
        dm.setSection(section)
        global_section = dm.getGlobalSection()
        #: the PetscSections of the dofs (None after release_setup)
        self.section: PETSc.Section | None = section
        self.global_section: PETSc.Section | None = global_section
        lg = dm.getLGMap().getIndices()           # collective: every process, with or without dofs
        #: global index of every local dof (-1 constrained)
        self.lg: IntArray = np.asarray(lg, dtype=PETSc.IntType)
        self._index_arrays(self.lg, section, global_section)

    # -- section ------------------------------------------------------------
    def _dofs_per_field(self) -> IntArray:
        n, d = len(self.enriched), self.dim
        return np.c_[np.full(n, d), d * self.enriched, self.multiplier, (d - 1) * self.multiplier].astype(np.int64)

    def _build_section(self) -> PETSc.Section:
        """A PetscSection with one field holding every dof of a node (a field per kind
        cost one more section over the whole chart each).  Within a point the dofs
        keep the order (DX, DY, [H1X, H1Y], [LAGS_C, LAGS_F1]); the constraints are the
        fixed ones.  (The chart is the DMPlex's: PETSc 3.18 checks constraint
        indices against the wrong points when a chart does not start at 0.)"""
        mesh = self.mesh
        sec = PETSc.Section().create(comm=mesh.comm)
        pts = mesh.node_points
        sec.setChart(*mesh.plex.getChart())
        per_field = self._dofs_per_field()
        ncons = self.fixed.sum(axis=1)
        points = pts.tolist()
        # every node carries DX, DY: map() keeps the per-point calls out of the interpreter loop
        list(map(sec.setDof, points, per_field.sum(axis=1).tolist()))
        special = np.nonzero(ncons > 0)[0]
        list(map(sec.setConstraintDof, pts[special].tolist(), ncons[special].tolist()))
        sec.setUp()
        it = PETSc.IntType
        for i in special.tolist():
            sec.setConstraintIndices(points[i], np.nonzero(self.fixed[i])[0].astype(it))
        return sec

    # -- index arrays -------------------------------------------------------
    def _index_arrays(self, lg: IntArray, section: PETSc.Section, global_section: PETSc.Section) -> None:
        mesh = self.mesh
        pstart, pend = mesh.plex.getChart()
        dof_of_point = np.zeros(pend - pstart, dtype=np.int64)
        per_field = self._dofs_per_field()
        dof_of_point[mesh.node_points] = per_field.sum(axis=1)
        off_of_point = np.concatenate([[0], np.cumsum(dof_of_point)[:-1]])
        off: IntArray = off_of_point[mesh.node_points]
        if len(off):
            probe = int(mesh.node_points[-1])
            assert section.getOffset(probe) == off[-1], "unexpected PetscSection layout"
        self.local_size = int(dof_of_point.sum())
        #: index of an extra slot, always zero, that absent dofs of a batch point to;
        #: local work arrays have ``local_size + 1`` entries
        self.dummy = self.local_size
        # index arrays in PETSc's integer type (half the memory of int64 with 32-bit PETSc)
        it = PETSc.IntType
        e = self.enriched
        d = self.dim
        off = off.astype(it)
        comps = np.arange(d, dtype=it)
        #: ``(n, d)`` local DX, DY, [DZ] dof of every node
        self.u_local: IntArray = off[:, None] + comps
        #: ``(n, d)`` local H1X, H1Y, [H1Z] dof of every node (-1 where not enriched)
        self.h_local: IntArray = np.where(e[:, None], off[:, None] + d + comps, it(-1))
        self._derived: dict[str, IntArray] = {}     # the arrays below, computed on first use (see release_setup)
        constrained = np.zeros(self.local_size, dtype=bool)
        constrained[self.u_local[self.fixed[:, :d]]] = True
        hfix = self.h_local[self.fixed[:, d:]]
        constrained[hfix[hfix >= 0]] = True
        #: local indices of the free (unconstrained) dofs
        self.free_local: IntArray = np.nonzero(~constrained)[0].astype(it)
        #: True when the global dofs are the free local dofs in order (one process)
        self.identity = bool(mesh.comm.size == 1 and np.array_equal(
            lg[self.free_local], np.arange(len(self.free_local), dtype=it)))
        self.owned_size: int = global_section.getConstrainedStorageSize()
        self.global_size: int = self.mesh.comm.tompi4py().allreduce(self.owned_size)
        self.ownership_start: int = self.mesh.comm.tompi4py().exscan(self.owned_size) or 0

    # -- derived index arrays (recomputed after release_setup if asked for) ----
    @property
    def lag_local(self) -> IntArray:
        """``(n, d)`` local LAGS_C, LAGS_F1, [LAGS_F2] dof of every node (-1 where absent)."""
        if "lag_local" not in self._derived:
            it, d = PETSc.IntType, self.dim
            lag0 = self.u_local[:, 0] + d + d * self.enriched.astype(it)
            self._derived["lag_local"] = np.where(self.multiplier[:, None], lag0[:, None] + np.arange(d, dtype=it),
                                                  it(-1))
        return self._derived["lag_local"]

    def _global(self, name: str, local: IntArray) -> IntArray:
        if name not in self._derived:
            it, lg = PETSc.IntType, self.lg
            if not len(lg):
                g = np.full(local.shape, -1, it)
            else:
                g = np.where(local >= 0, lg[np.maximum(local, 0)], it(-1))
                g = np.where(g >= 0, g, it(-1))
            self._derived[name] = g
        return self._derived[name]

    @property
    def u_global(self) -> IntArray:
        """``(n, d)`` global DX, DY, [DZ] dof of every node (-1: constrained)."""
        return self._global("u_global", self.u_local)

    @property
    def h_global(self) -> IntArray:
        """``(n, d)`` global H1X, H1Y, [H1Z] dof (-1: absent or constrained)."""
        return self._global("h_global", self.h_local)

    @property
    def lag_global(self) -> IntArray:
        """``(n, d)`` global LAGS_C, LAGS_F1, [LAGS_F2] dof (-1: absent)."""
        return self._global("lag_global", self.lag_local)

    # -- vectors ------------------------------------------------------------
    def create_global_vec(self) -> PETSc.Vec:
        """A global vector (this process's ``owned_size`` free dofs, in global order)."""
        v = PETSc.Vec().create(comm=self.mesh.comm)
        v.setSizes((self.owned_size, self.global_size))
        v.setType(PETSc.Vec.Type.STANDARD)
        return v

    def create_local_vec(self) -> PETSc.Vec:
        """A sequential vector of this process's dofs (``local_size``), constrained ones included."""
        return PETSc.Vec().createSeq(self.local_size, comm=PETSc.COMM_SELF)

    @property
    def scatter(self) -> tuple[PETSc.Scatter, PETSc.Vec]:
        """``(Scatter, local Vec)`` from the free local dofs to their global entries (several
        processes only; built on first use): forward with ADD_VALUES sums the shared dofs
        of every process into their owner, reverse with INSERT_VALUES gives every process
        the values of its dofs."""
        if self._scatter is None:
            free = self.free_local
            it = PETSc.IntType
            lv = PETSc.Vec().createSeq(self.local_size, comm=PETSc.COMM_SELF)
            g = self.create_global_vec()
            src = PETSc.IS().createGeneral(free.astype(it), comm=PETSc.COMM_SELF)
            dst = PETSc.IS().createGeneral(self.lg[free].astype(it), comm=PETSc.COMM_SELF)
            self._scatter = (PETSc.Scatter().create(lv, src, g, dst), lv)
            src.destroy()
            dst.destroy()
            g.destroy()
        return self._scatter

    def release_setup(self) -> None:
        """Drop what only the set-up needed, before the factorisation (idempotent): the
        PetscSections, the DMPlex (:meth:`LocalMesh.release_topology`) and the global
        and multiplier index arrays (recomputed if asked for again).  Vectors and
        transfers do not depend on them.  TRIA6 N = 320: 62 MB."""
        self.section = self.global_section = None
        self._derived.clear()
        self.mesh.release_topology()

    def local_array(self) -> FloatArray:
        """A zero local work array (``local_size + 1`` entries, the last one the dummy)."""
        return np.zeros(self.local_size + 1)

    def counts(self) -> dict[str, int]:
        """Number of free dofs of each kind over all processes (collective the first time)."""
        if self._counts is None:
            self._counts = self._count_free()
        return dict(self._counts)

    def _count_free(self) -> dict[str, int]:
        owned = self.mesh.node_owned
        free = ~self.fixed
        d = self.dim
        mpi = self.mesh.comm.tompi4py()
        local = {
            "displacement": int(free[owned, :d].sum()),
            "heaviside": int((free[owned, d:] & self.enriched[owned, None]).sum()),
            "LAGS_C": int(self.multiplier[owned].sum()),
            "LAGS_F1": int(self.multiplier[owned].sum()),
        }
        if d == 3:
            local["LAGS_F2"] = local["LAGS_F1"]
        return {k: mpi.allreduce(v) for k, v in local.items()}
