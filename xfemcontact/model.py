"""A case, set up on the distributed mesh and ready to solve.

    model = Model.from_case(load_case("cases/ssnv509a.toml"))
    model.solve()
    model.displacement()       # (n, 2) DX, DY at this process's nodes

The model holds the mesh, the cut geometry, the dof layout and the bulk
system; the interface's terms and state belong to its
:class:`~xfemcontact.contact.problem.InterfaceProblem` (``model.problem``,
made by the interface law once), and the SNES objects and what they did to the
:class:`~xfemcontact.solver.nonlinear.NonlinearSolver` (``model.solver``).

The phases are PETSc log events (``-log_view``) and their wall times are kept
in :data:`xfemcontact.timing.TIMINGS`.
"""
from __future__ import annotations

import dataclasses
import time
from typing import TYPE_CHECKING, Any

import numpy as np
from mpi4py import MPI

from xfemcontact import preflight
from xfemcontact._petsc import PETSc
from xfemcontact.assembly import pattern, system
from xfemcontact.case.instant import case_at
from xfemcontact.fem.coordinates import coordinates
from xfemcontact.contact import laws
from xfemcontact.contact.problem import InterfaceSetup
from xfemcontact.dofs import constraints
from xfemcontact.dofs.layout import DofLayout
from xfemcontact.errors import MeshError
from xfemcontact.fem.elasticity import hooke
from xfemcontact.mesh import plex
from xfemcontact.mesh.build import build_raw_mesh
from xfemcontact.post import fields
from xfemcontact.solver.newton import matrix_format
from xfemcontact.solver.nonlinear import NonlinearSolver
from xfemcontact.timing import phase, release_heap
from xfemcontact.xfem import geometry, integration, integration3d, levelset

#: the coarse start (:meth:`Model.coarse_start`) is a start: its threshold loop stops at this
#: RESI_FROT (or the case's, if looser) and after COARSE_ITER_FROT threshold iterations (or the
#: case's ITER_FROT_MAXI, if fewer); not converged, it is not used.  Measured on 56 curved cases
#: (floating circles, ellipses and tilted ellipses, 4 stress states, mu = 0.2 and 0.6, QUAD8
#: and TRIA6, and the curved cases of the campaign): the stable space's threshold loop cycled
#: on two of them for 292 and 309 Newton iterations (381 and 345 in all) before they went on
#: from the sticking start; with these 187 and 69, every other case within 1 iteration of
#: what it took; the converged coarse starts took 2 - 13 threshold iterations to 1e-6
COARSE_RESI_FROT = 1e-2
COARSE_ITER_FROT = 10

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.case.load import Case
    from xfemcontact.contact.problem import InterfaceProblem
    from xfemcontact.contact.space import MultiplierSpace
    from xfemcontact.mesh.plex import LocalMesh
    from xfemcontact.mesh.raw import RawMesh
    from xfemcontact.post.fields import PointValues
    from xfemcontact.post.testtable import Samples
    from xfemcontact.xfem.geometry import Geometry
    from xfemcontact.xfem.integration import SegmentPoints
    from xfemcontact.xfem.integration3d import FacetPoints

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]

__all__ = ["Model", "build_raw_mesh"]

#: degree of the triangle rule on the 3-D interface facets of a contact interface (exact
#: for the products of the vertex functions with the jump on planar cuts of affine
#: TETRA10 cells, and for the lumped weights int phi_a dA of HEXA20's trilinear phi_a)
INTERFACE_DEGREE_3D = 4


class Model:
    """Mesh, geometry, dofs and assembled bulk system of a case on every process.

    Attributes: ``case``, ``comm``, ``mesh`` (:class:`~xfemcontact.mesh.plex.Mesh`),
    ``D`` (Hooke matrix, Pa), ``geo`` (cut geometry, None without interface),
    ``law`` (the :class:`~xfemcontact.contact.laws.InterfaceLaw`, None without
    interface), ``layout``, ``problem`` (None without interface), ``K`` (the
    Jacobian matrix: bulk stiffness plus the last interface tangent), ``f0``
    (global Vec: forces of the imposed displacements minus external forces, N),
    ``load_norm`` (its norm), ``x`` (global solution Vec), ``solver`` (after
    :meth:`solve`), ``warnings`` (lines of the set-up).
    """

    case: Case
    comm: PETSc.Comm
    warnings: list[str]
    mesh: LocalMesh
    D: FloatArray
    geo: Geometry | None
    law: laws.InterfaceLaw | None
    layout: DofLayout
    x_bc: FloatArray                  # local work array of the imposed values
    problem: InterfaceProblem | None
    K: PETSc.Mat
    f0: PETSc.Vec
    load_norm: float
    x: PETSc.Vec
    solver: NonlinearSolver | None
    _K_int: FloatArray | None
    _bulk_kept: bool

    def __init__(self, case: Case, raw: RawMesh | None = None, comm: PETSc.Comm | None = None) -> None:
        self.case = case
        self.comm = comm or PETSc.COMM_WORLD
        self.warnings = []
        with phase("mesh"):
            if raw is None and self.comm.rank == 0:
                raw = build_raw_mesh(case)
            weights = None
            if self.comm.size > 1 and self.comm.rank == 0:
                from xfemcontact.mesh.partition import cut_cell_weights

                itf = case.interface
                assert raw is not None               # rank 0 has the input mesh
                weights = cut_cell_weights(raw, itf.level_set if itf is not None else None)
            self.mesh = plex.load(raw, self.comm, weights)
            case.check_groups(self.mesh.group_names())
        mat = case.material
        self.D = hooke(mat.E, mat.nu, mat.model)
        with phase("levelset"):
            self.geo = self._geometry()
        itf = case.interface             # a geometry means an interface
        self.law = laws.get(itf.law) if self.geo is not None and itf is not None else None
        with phase("layout"):
            self._layout()
        with phase("assembly"):
            self._assemble()
        self.x = self.layout.create_global_vec()
        self.x.set(0.0)
        self.solver = None
        #: the instant of a load history whose loads :meth:`set_loads` put in (None: the case's
        #: own loads); the coarse start solves the case at that instant (:meth:`coarse_start`)
        self.load_instant: float | None = None

    @classmethod
    def from_case(cls, case: Case, raw: RawMesh | None = None) -> Model:
        return cls(case, raw)

    # -- set-up -------------------------------------------------------------
    def _geometry(self) -> Geometry | None:
        itf = self.case.interface
        if itf is None:
            return None
        mesh = self.mesh
        field = None
        if itf.level_set_field is not None:
            field = (mesh.node_data or {}).get(itf.level_set_field)
            if field is None:
                names = ", ".join(sorted(mesh.node_data or {})) or "none"
                raise MeshError(f"{self.case.source}: interface.level_set_field: no nodal field "
                                f"'{itf.level_set_field}' in {mesh.source} (nodal fields: {names})")
        phi = levelset.nodal_values(mesh, itf, field)
        missed = preflight.levelset_meets_domain(phi, mesh.x, comm=self.comm.tompi4py(),
                                                 source=self.case.source)
        if missed:                       # no interface in the domain: solve without one
            self.warnings.append(missed)
            return None
        return geometry.build(mesh, phi)

    def _layout(self) -> None:
        mesh, geo, law = self.mesh, self.geo, self.law
        x = mesh.x
        fixed, values = constraints.fixed_components(
            mesh, self.case, geo, law, lambda nodes, f: f(**coordinates(x[nodes])))
        enriched = geo.enriched if geo is not None else np.zeros(len(x), bool)
        multiplier = np.zeros(len(x), bool)
        space: MultiplierSpace | None = None
        points: SegmentPoints | FacetPoints | None = None
        if geo is not None and mesh.dim == 3 and law is not None:
            points = integration3d.concat(geo.interface_points(mesh, INTERFACE_DEGREE_3D))
            if law.multipliers:
                space = law.multiplier_space(mesh, geo, points, self.case)
                assert space is not None            # a law with multipliers gives its space
                multiplier = space.carriers(mesh)
        elif geo is not None and mesh.dim == 2:
            assert law is not None                  # an interface has its law
            segs = geo.segments()
            xc = x[mesh.cell_nodes[segs.cells]]
            points = integration.segment_points(mesh.element, xc, segs, self._interface_order(xc),
                                                mesh.cell_ids[segs.cells])
            space = law.multiplier_space(mesh, geo, points, self.case)
            if space is not None:
                multiplier = space.carriers(mesh)
        self.layout = DofLayout(mesh, enriched, multiplier, fixed)
        self.x_bc = system.bc_array(self.layout, fixed, values)
        self.problem = None
        if geo is not None and points is not None:
            assert law is not None                              # set above
            self.problem = law.problem(InterfaceSetup(mesh, geo, self.layout, points, space, self.case))

    def _interface_order(self, xc: FloatArray) -> int:
        """Gauss points per interface segment: ``[contact] ordre_int``, else 4 (code_aster's)
        when every cut cell of every process is affine, 8 otherwise (on a distorted
        quadrangle the shape functions are rational along the interface: 4 points
        left straight interfaces 1e-5 off on Gmsh quadrangles, 8 points 3e-6)."""
        order = self.case.contact.ordre_int
        if order is not None:
            return order
        from mpi4py import MPI

        from xfemcontact.fem.elements import affine_cells

        distorted = bool(len(xc)) and not affine_cells(self.mesh.element, xc).all()
        return 8 if self.comm.tompi4py().allreduce(distorted, op=MPI.LOR) else 4

    def _assemble(self) -> None:
        mesh, geo, layout, problem = self.mesh, self.geo, self.layout, self.problem
        blocks, remote = [mesh.cell_nodes], None
        if problem is not None and problem.pattern_points is not None:
            blocks.append(problem.pattern_points)
            remote = problem.remote_points
        self.K = pattern.create_matrix(layout, blocks, remote, symmetric=matrix_format() == "sbaij")
        if problem is not None and problem.indices is not None:
            self._zero_interface_pattern(self.K, problem.indices)
        lift = layout.local_array()
        system.assemble_bulk(mesh, geo, layout, self.D, self.K, lift, self.x_bc)
        self.K.assemble()
        f_ext = layout.local_array()
        if self.case.body_force is not None:
            system.add_body_forces(mesh, geo, layout, self.case.body_force, f_ext)
        system.add_tractions(mesh, geo, layout, self.case.traction, f_ext)
        self.f0 = system.local_to_global(layout, lift - f_ext)
        self.load_norm = self.f0.norm()
        # one matrix: K = K_bulk + (interface tangent of the last Jacobian, K_int)
        self._K_int = None
        self._bulk_kept = False

    def _zero_interface_pattern(self, A: PETSc.Mat, indices: IntArray) -> None:
        """Explicit zeros on every interface coupling (the global dofs ``indices`` of the
        interface elements), so the pattern never changes."""
        g = indices.astype(PETSc.IntType)
        if len(g) == 0:           # petsc4py divides by the batch size
            return
        A.setValuesRCV(g, g, np.zeros((len(g), g.shape[1], g.shape[1])),
                       addv=PETSc.InsertMode.ADD_VALUES)

    # -- Newton callbacks -----------------------------------------------------
    def residual(self, snes: PETSc.SNES, x: PETSc.Vec, f: PETSc.Vec) -> None:
        """R(x) = K_bulk x + f0 + R_interface(x), with K_bulk x = K x - K_int x."""
        self.K.mult(x, f)
        f.axpy(1.0, self.f0)
        if self.problem is not None:
            if self._K_int is not None:
                self.problem.add_product(self._K_int, x, f, -1.0)
            self.problem.add_residual(x, f)

    def merit(self, x: PETSc.Vec, f: PETSc.Vec) -> float:
        """The squared norm of the merit function at ``x`` (the problem's
        :meth:`~xfemcontact.contact.nodal_problem.NodalContactProblem.merit_norm`: the bulk
        rows K_bulk x + f0 with the interface tractions of every dof, and the complementarity
        functions at the dofs); ``f`` a work vector."""
        assert self.problem is not None
        self.K.mult(x, f)
        f.axpy(1.0, self.f0)
        if self._K_int is not None:
            self.problem.add_product(self._K_int, x, f, -1.0)
        self.problem.add_merit_residual(x, f)
        return self.problem.merit_norm(f) ** 2

    def jacobian(self, snes: PETSc.SNES, x: PETSc.Vec, J: PETSc.Mat, P: PETSc.Mat) -> None:
        """J = K_bulk + K_int(x): replace the previous interface tangent in place.

        When no process's interface tangent changed, J is not touched: PETSc then
        keeps the factorisation of the previous solve (the operator's state is
        unchanged), which is what a status or threshold iteration that changes
        nothing in the tangent costs."""
        if self.problem is None:
            return
        new = self.problem.tangent(x)
        if new is None:
            return
        from mpi4py import MPI

        same = self._K_int is not None and np.array_equal(new, self._K_int)
        if self.comm.tompi4py().allreduce(same, op=MPI.LAND):
            return
        if self._bulk_kept:                 # J = bulk + new exactly, whatever came before
            J.retrieveValues()
            self.problem.add_matrices(J, new)
        else:
            self.problem.add_matrices(J, new if self._K_int is None else new - self._K_int)
        self._K_int = new
        J.assemble()

    def keep_bulk_values(self) -> None:
        """Keep a copy of the bulk matrix values (PETSc MatStoreValues) so that every new
        interface tangent replaces the previous one exactly: the Jacobian is then a
        function of the tangent alone, not of the tangents before it, and a run resumed
        from a checkpoint factorises the same matrices as the uninterrupted one.  Costs
        one copy of the matrix values; used by runs with load steps, before the first
        solve."""
        if self.problem is None or self._bulk_kept:
            return
        self.K.setOption(PETSc.Mat.Option.NEW_NONZERO_LOCATIONS, False)
        self.K.storeValues()
        self._bulk_kept = True

    def interface_tangent(self) -> FloatArray | None:
        """The interface element tangents in the Jacobian now (None: none yet)."""
        return self._K_int

    def set_interface_tangent(self, K: FloatArray | None) -> None:
        """Put the interface tangents ``K`` into the Jacobian (a run resumed from a
        checkpoint: the Jacobian of the step it stopped at), with the bulk values kept
        by :meth:`keep_bulk_values`."""
        if self.problem is None or not self._bulk_kept:
            return
        self.K.retrieveValues()
        if K is not None:
            self.problem.add_matrices(self.K, K)
        self.K.assemble()
        self._K_int = K

    def set_loads(self, x_bc: FloatArray, f0: PETSc.Vec, load_norm: float, t: float) -> None:
        """The loads of another instant ``t`` (:mod:`xfemcontact.history.loading`): imposed
        values ``x_bc`` (local work array), ``f0`` (global Vec) and the reference of
        Newton's relative criterion ``load_norm``.  The bulk matrix does not change."""
        self.x_bc, self.f0, self.load_norm = x_bc, f0, load_norm
        self.load_instant = t

    # -- solve --------------------------------------------------------------
    def solve(self) -> int:
        """Newton (inside the outer loops of the interface problem, if any); returns the
        outermost SNES converged reason (> 0 converged).  Called again (the next load
        step), it reuses the solver: its record goes on, and a tangent that has not
        changed keeps its factorisation."""
        if self.solver is None:
            self.solver = NonlinearSolver(self)
            if self.mesh.dim == 2 and self.problem is not None:
                self.solver.coarse_start = self.coarse_start
        self.layout.release_setup()      # PetscSections and DMPlex: not needed from here on
        release_heap()
        with phase("solve"):
            reason = self.solver.solve(self.x)
        if reason > 0 and self.problem is not None:
            self.problem.check_conditions(self.x)
        return reason

    def coarse_start(self, x: PETSc.Vec) -> dict[str, Any]:
        """Replace the sticking start ``x`` by the solution of the same case in the stable
        multiplier space (``algo_lagr = "STABLE"``, 2-D), when the problem asks for it
        (:meth:`~xfemcontact.contact.problem.InterfaceProblem.wants_coarse_start`).

        The rich default space has nearly invisible differences between the vertex multipliers
        on either side of a curved interface; from the sticking start Newton can wander between
        near-solutions of its discrete law (a body held by friction alone: 278 Newton
        iterations and a forced status loop, bench/inclusion_family.py).  The stable space has
        none (8), and from its answer Newton in the rich space converges in a few iterations
        (9): the answer is the rich space's, only the start changes.  The coarse model is built
        and solved like this one (its own mesh distribution, layout and factors, released
        after), its displacements, Heaviside dofs and multipliers copied into ``x`` by input
        node ids (a rich-space carrier takes the value of its star in the stable space).
        Being a start, it is solved to RESI_FROT = COARSE_RESI_FROT at most and given
        COARSE_ITER_FROT threshold iterations at most.
        Returns what it did (results.json ``iterations.coarse_start``); ``x`` is left as it was
        if the coarse solve did not converge."""
        t0 = time.perf_counter()
        case = self.case
        if self.load_instant is not None:        # the first step of a load history: its loads
            case = case_at(case, self.load_instant)
        c = case.contact
        case = dataclasses.replace(case, contact=dataclasses.replace(
            c, algo_lagr="STABLE", resi_frot=max(c.resi_frot, COARSE_RESI_FROT),
            iter_frot_maxi=min(c.iter_frot_maxi, COARSE_ITER_FROT)))
        coarse = Model(case)
        coarse.solver = NonlinearSolver(coarse)
        reason = coarse.solver.solve(coarse.x)
        its = coarse.solver.iterations()
        done = {"algo_lagr": "STABLE", "converged": reason > 0, "newton": int(its["newton"]),
                "threshold_iterations": int(its.get("friction", 0)), "used": False}
        if reason > 0:
            done["used"] = self._take_start(coarse, x)
        coarse.release_factors()
        done["seconds"] = round(time.perf_counter() - t0, 4)
        return done

    def _take_start(self, coarse: Model, x: PETSc.Vec) -> bool:
        """Copy the solution of ``coarse`` (the same case, another multiplier space) into ``x``
        (this model's layout), matching nodes by input id; False (``x`` unchanged) if a dof
        has no counterpart (all processes)."""
        mpi = self.comm.tompi4py()
        la = coarse.local_solution()
        ids_c, ids = coarse.mesh.node_ids, self.mesh.node_ids
        order = np.argsort(ids_c)
        at = order[np.clip(np.searchsorted(ids_c, ids, sorter=order), 0, len(ids_c) - 1)]
        found = ids_c[at] == ids
        lo, hi = x.getOwnershipRange()
        xb = x.getArray().copy()
        ok = True
        for g, loc in ((self.layout.u_global, coarse.layout.u_local), (self.layout.h_global, coarse.layout.h_local)):
            own = (g >= lo) & (g < hi)
            src = np.where(found[:, None], loc[at], -1)
            ok &= not (own & (src < 0)).any()
            xb[g[own] - lo] = la[np.maximum(src, 0)[own]]
        # the stable space's carrier values, by input id, from every process
        lag_c = coarse.layout.lag_local
        have = lag_c[:, 0] >= 0
        parts = mpi.allgather((coarse.mesh.node_ids[have], la[lag_c[have]]))
        gid = np.concatenate([p[0] for p in parts])
        val = np.concatenate([p[1] for p in parts])
        gid, first = np.unique(gid, return_index=True)
        val = val[first]
        g = self.layout.lag_global
        own = (g[:, 0] >= lo) & (g[:, 0] < hi)
        space = coarse.problem.space if coarse.problem is not None else None
        if own.any():
            if space is None or not np.isin(ids[own], space.ids).all():
                ok = False
            else:
                rep = space.representative(ids[own])
                k = np.clip(np.searchsorted(gid, rep), 0, len(gid) - 1)
                ok &= bool((gid[k] == rep).all())
                xb[g[own] - lo] = val[k]
        ok = bool(mpi.allreduce(ok, op=MPI.LAND))
        if ok:
            x.setArray(xb)
        return ok

    def run_warnings(self) -> list[str]:
        """Warnings of the solve (one line each)."""
        found = list(self.problem.warnings) if self.problem is not None else []
        return found + (self.solver.warnings() if self.solver is not None else [])

    def release_factors(self) -> None:
        """Free the factorisation (after the solve): post-processing reuses its memory."""
        if self.solver is not None:
            self.solver.release()

    def solver_info(self) -> dict[str, Any] | None:
        """Linear solver facts (see :meth:`NonlinearSolver.info`), None before :meth:`solve`."""
        return self.solver.info() if self.solver is not None else None

    # -- results ------------------------------------------------------------
    def local_solution(self) -> FloatArray:
        """Local work array of the solution, imposed values included."""
        return system.global_to_local(self.layout, self.x, self.x_bc)

    def interface_values(self) -> dict[str, NDArray[Any]] | None:
        """Interface point values of this process (see InterfaceProblem.point_values)."""
        return self.problem.point_values(self.x) if self.problem is not None else None

    def interface_samples(self) -> dict[str, Samples]:
        """Samples of the interface fields for test tables."""
        from xfemcontact.post.testtable import Samples

        v = self.interface_values()
        if v is None:
            return {}
        names = ("LAGS_C", "LAGS_F1", "gap", "slip") + (("LAGS_F2",) if "LAGS_F2" in v else ())
        return {"interface": Samples(v["x"], v["y"], {k: v[k] for k in names}, v.get("z"))}

    def displacement(self) -> FloatArray:
        """``(n, 2)`` DX, DY at this process's nodes, m."""
        return fields.nodal_displacement(self.layout, self.local_solution())

    def stresses(self) -> list[PointValues]:
        """Stresses at the quadrature points of every local cell."""
        return fields.quadrature_stresses(self.mesh, self.geo, self.layout, self.D, self.local_solution())
