"""A case, set up on the distributed mesh and ready to solve.

    model = Model.from_case(load_case("cases/ssnv509a.toml"))
    model.solve()
    model.displacement()       # (n, 2) DX, DY at this process's nodes

The phases are PETSc log events (``-log_view``) and their wall times are kept
in :data:`xfemcontact.timing.TIMINGS`.
"""
import numpy as np

from xfemcontact._petsc import PETSc
from xfemcontact.assembly import pattern, system
from xfemcontact.contact import law as claw
from xfemcontact.contact import space as cspace
from xfemcontact.contact.operator import InterfaceOperator
from xfemcontact.dofs import constraints
from xfemcontact.dofs.layout import DofLayout
from xfemcontact.errors import MeshError
from xfemcontact.fem.elasticity import hooke
from xfemcontact.mesh import plex
from xfemcontact.post import fields
from xfemcontact.solver.loops import create_loops, solve_newton
from xfemcontact.solver.newton import create_snes, matrix_format
from xfemcontact.timing import phase, release_heap
from xfemcontact.xfem import geometry, integration, levelset


def _mumps_count(v):
    """MUMPS writes large counts as negative millions."""
    return int(v) if v >= 0 else int(-v) * 1000000


def build_raw_mesh(case):
    """The case's mesh on rank 0 (read or generated, refined); None elsewhere."""
    if PETSc.COMM_WORLD.rank != 0:
        return None
    from xfemcontact.mesh.generate import rectangle
    from xfemcontact.mesh.read import read_mesh
    from xfemcontact.mesh.refine import refine_uniform

    spec = case.mesh
    raw = read_mesh(spec.file, display_name=spec.file.name) if spec.file else rectangle(**spec.rectangle)
    if spec.refine:
        raw = refine_uniform(raw, spec.refine)
    return raw


class Model:
    """Mesh, geometry, dofs and assembled bulk system of a case on every process."""

    def __init__(self, case, raw=None, comm=None):
        self.case = case
        self.comm = comm or PETSc.COMM_WORLD
        with phase("mesh"):
            if raw is None and self.comm.rank == 0:
                raw = build_raw_mesh(case)
            weights = None
            if self.comm.size > 1 and self.comm.rank == 0:
                from xfemcontact.mesh.partition import cut_cell_weights

                itf = case.interface
                weights = cut_cell_weights(raw, itf.level_set if itf is not None else None)
            self.mesh = plex.load(raw, self.comm, weights)
            case.check_groups(self.mesh.group_names())
        mat = case.material
        self.D = hooke(mat.E, mat.nu, mat.model)
        with phase("levelset"):
            self.geo = self._geometry()
        with phase("layout"):
            self._layout()
        with phase("assembly"):
            self._assemble()
        self.x = self.layout.create_global_vec()
        self.x.set(0.0)
        self.snes = None
        self.loops = None
        self.n_jacobians = 0
        self.linear_failure = None     # see solver.loops.solve_newton
        self.solver_warnings = []      # likewise (MUMPS work space raised)

    @classmethod
    def from_case(cls, case, raw=None):
        return cls(case, raw)

    # -- set-up -------------------------------------------------------------
    def _geometry(self):
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
        from xfemcontact import checks

        self.warnings = []
        missed = checks.levelset_meets_domain(phi, mesh.x, comm=self.comm.tompi4py(), source=self.case.source)
        if missed:                       # no interface in the domain: solve without one
            self.warnings.append(missed)
            return None
        return geometry.build(mesh, phi)

    @property
    def has_contact(self):
        itf = self.case.interface
        return itf is not None and itf.law == "contact" and self.geo is not None

    def _layout(self):
        mesh, geo = self.mesh, self.geo
        x = mesh.x
        fixed, values = constraints.fixed_components(
            mesh, self.case, geo, lambda nodes, f: f(x=x[nodes, 0], y=x[nodes, 1]))
        enriched = geo.enriched if geo is not None else np.zeros(len(x), bool)
        multiplier = np.zeros(len(x), bool)
        self.space = None
        if geo is not None:
            segs = geo.segments()
            el = mesh.element
            self.segment_points = integration.segment_points(
                el, x[mesh.cell_nodes[segs.cells]], segs, self.case.contact.ordre_int, mesh.cell_ids[segs.cells])
        if self.has_contact:
            sp = self.segment_points
            self.space = cspace.build(mesh, segs, self.case.contact.algo_lagr,
                                      el.shape_linear(sp.xi), sp.w)
            multiplier = self.space.carriers(mesh)
        self.fixed, self.values = fixed, values
        self.layout = DofLayout(mesh, enriched, multiplier, fixed)
        self.x_bc = system.bc_array(self.layout, fixed, values)
        if self.space is not None:
            self._multiplier_dofs()

    def _multiplier_dofs(self):
        """Global LAGS_C index of every segment vertex, and remote carriers for the pattern."""
        mesh, layout, space = self.mesh, self.layout, self.space
        own = layout.multiplier & mesh.node_owned
        mpi = self.comm.tompi4py()
        parts = mpi.allgather((mesh.node_ids[own], layout.lag_global[own, 0]))
        ids = np.concatenate([p[0] for p in parts])
        idx = np.concatenate([p[1] for p in parts])
        owner = np.concatenate([np.full(len(p[0]), r) for r, p in enumerate(parts)])
        order = np.argsort(ids)
        ids, idx, owner = ids[order], idx[order], owner[order]
        segs = self.geo.segments()
        co = space.carriers_of
        live = co >= 0
        rep = space.representative(np.where(live, co, space.ids[0]))
        pos = np.searchsorted(ids, rep)
        self.rep_index = np.where(live, idx[pos], -1)
        # carriers as points of the matrix pattern: a local node, or a remote point
        vloc = np.argsort(mesh.node_ids[: mesh.n_vertices])
        vids = mesh.node_ids[: mesh.n_vertices][vloc]
        if len(vids):
            j = np.minimum(np.searchsorted(vids, rep), len(vids) - 1)
            local = (vids[j] == rep) & live
            point = np.where(local, vloc[j], -1)
        else:
            local = np.zeros(rep.shape, bool)
            point = np.full(rep.shape, -1)
        remote_ids, rpos = np.unique(rep[~local & live], return_inverse=True)
        point[~local & live] = len(mesh.x) + rpos
        rp = np.searchsorted(ids, remote_ids)
        self.remote_points = (idx[rp], np.full(len(rp), 2), owner[rp])
        self.interface_points = np.concatenate([mesh.cell_nodes[segs.cells], point], axis=1)

    def _couplings(self):
        """Point lists of every element coupling (for the matrix pattern)."""
        blocks = [self.mesh.cell_nodes]
        if self.space is not None:
            blocks.append(self.interface_points)
        return blocks

    def _assemble(self):
        mesh, geo, layout = self.mesh, self.geo, self.layout
        self.interface = None
        if self.space is not None:
            c = self.case.contact
            unknown = PETSc.Options().getString("xfc_friction_unknown", c.friction_unknown).upper()
            rho_T = max(c.coef_cont, c.coulomb * c.coef_frot * abs(c.seuil_init or 0.0))
            self.law = claw.Law(c.coef_cont, c.coef_frot, c.coulomb, c.friction,
                                unknown="traction" if unknown == "TRACTION" else "semi-multiplier",
                                rho_T=rho_T)
            self.interface = InterfaceOperator(mesh, geo, layout, self.space, self.rep_index, self.law,
                                               self.segment_points, c.contact_init is not False,
                                               c.seuil_init)
        self.interface_probe = self._probe() if self.interface is None and geo is not None else None
        remote = self.remote_points if self.space is not None else None
        self.K = pattern.create_matrix(layout, self._couplings(), remote,
                                       symmetric=matrix_format() == "sbaij")
        if self.interface is not None:
            self._zero_interface_pattern(self.K)
        lift = layout.local_array()
        system.assemble_bulk(mesh, geo, layout, self.D, self.K, lift, self.x_bc)
        self.K.assemble()
        f_ext = layout.local_array()
        if self.case.body_force is not None:
            system.add_body_forces(mesh, geo, layout, self.case.body_force, f_ext)
        system.add_tractions(mesh, geo, layout, self.case.traction, f_ext)
        self.f0 = system.local_to_global(layout, lift - f_ext)
        self.load_norm = self.f0.norm()
        # one matrix: J = K_bulk + (interface tangent of the last Jacobian, K_int)
        self.J = self.K
        self.K_int = None

    def _probe(self):
        """An interface operator for the results only (laws ``free`` and ``bonded``: no
        multipliers, nothing assembled): gap and slip at the interface points, LAGS_C =
        LAGS_F1 = 0; "contact" is 1 for ``bonded``, 0 for ``free``."""
        k = len(self.geo.segments())
        nv = self.mesh.element.nv
        empty = cspace.MultiplierSpace(np.zeros(0, np.int64), np.zeros(0, np.int64), None,
                                       np.zeros((k, 0), np.int64), np.zeros((k, nv, 0)), algo="NON")
        law = claw.Law(1.0, 1.0, 0.0, False)
        return InterfaceOperator(self.mesh, self.geo, self.layout, empty, np.zeros((k, 0), np.int64), law,
                                 self.segment_points, self.case.interface.law == "bonded")

    def _zero_interface_pattern(self, A):
        """Explicit zeros on every interface coupling, so the pattern never changes."""
        from xfemcontact._petsc import PETSc

        g = self.interface.gidx.astype(PETSc.IntType)
        if len(g) == 0:           # petsc4py divides by the batch size
            return
        A.setValuesRCV(g, g, np.zeros((len(g), g.shape[1], g.shape[1])),
                       addv=PETSc.InsertMode.ADD_VALUES)

    # -- solve --------------------------------------------------------------
    def residual(self, snes, x, f):
        """R(x) = K_bulk x + f0 + R_interface(x), with K_bulk x = J x - K_int x."""
        self.J.mult(x, f)
        f.axpy(1.0, self.f0)
        if self.interface is not None:
            if self.K_int is not None:
                self.interface.add_product(self.K_int, x, f, -1.0)
            self.interface.add_residual(x, f)

    def jacobian(self, snes, x, J, P):
        """J = K_bulk + K_int(x): replace the previous interface tangent in place."""
        self.n_jacobians += 1
        if self.interface is None:
            return
        new = self.interface.element_matrices(x)
        self.interface.add_matrices(J, new if self.K_int is None else new - self.K_int)
        self.K_int = new
        J.assemble()

    def solve(self):
        """Newton (inside the contact loops if any); returns the outermost converged reason."""
        newton = self.case.newton
        f = self.layout.create_global_vec()
        self.snes, self.newton_test = create_snes(
            self.comm, self.residual, self.jacobian, self.J, f,
            newton.resi_glob_rela, newton.iter_glob_maxi, lambda: self.load_norm)
        self.loops = None
        release_heap()
        with phase("solve"):
            if self.interface is None:
                solve_newton(self, self.snes, self.x)
                return self.snes.getConvergedReason()
            outer, self.contact_snes, self.loops = create_loops(self, self.snes, self.case.contact)
            self.outer_snes = outer
            outer.solve(None, self.x)
            return outer.getConvergedReason()

    def run_warnings(self):
        """Warnings of the solve: the linear solver's, then the loops' (one line each)."""
        return list(self.solver_warnings) + (list(self.loops.warnings) if self.loops else [])

    def release_factors(self):
        """Free the factorisation (after the solve): post-processing reuses its memory.

        The solver facts are kept for :meth:`solver_info`.
        """
        if self.snes is not None and getattr(self, "_solver_info", None) is None:
            self._solver_info = self.solver_info()
            self.snes.getKSP().reset()

    def solver_info(self):
        """Linear solver facts: type, factorisations, MUMPS statistics when MUMPS factors."""
        if getattr(self, "_solver_info", None) is not None:
            return self._solver_info
        if self.snes is None:
            return None
        ksp = self.snes.getKSP()
        pc = ksp.getPC()
        info = {"ksp": ksp.getType(), "pc": pc.getType(), "matrix": self.J.getType(),
                "jacobians": self.n_jacobians}
        try:
            info["solver"] = pc.getFactorSolverType()
        except Exception:      # not a factorising preconditioner
            return info
        if info["solver"] == "mumps" and self.n_jacobians:
            try:
                F = pc.getFactorMatrix()
            except PETSc.Error:     # dropped after a failed factorisation (solve_newton)
                if self.linear_failure is not None and self.linear_failure["mumps"]:
                    info["mumps"] = self.linear_failure["mumps"]
                return info
            info["mumps"] = {"null_pivots": int(F.getMumpsInfog(28)),
                             "status": int(F.getMumpsInfog(1)),
                             "factor_entries": _mumps_count(F.getMumpsInfog(29)),
                             "ordering": int(F.getMumpsInfog(7)),
                             "memory_mb_total": int(F.getMumpsInfog(31))}
        return info

    def lags_c(self, x):
        """LAGS_C dofs owned by this process."""
        own = self.layout.multiplier & self.mesh.node_owned
        idx = self.layout.lag_global[own, 0] - self.layout.ownership_start
        return x.getArray(readonly=True)[idx].copy()

    # -- results ------------------------------------------------------------
    def local_solution(self):
        """Local work array of the solution, imposed values included."""
        return system.global_to_local(self.layout, self.x, self.x_bc)

    @property
    def interface_post(self):
        """The interface operator that gives the results at the interface points: the
        contact one, or the probe of a ``free`` / ``bonded`` interface (None without one)."""
        return self.interface if self.interface is not None else self.interface_probe

    def interface_values(self):
        """Interface point values of this process (see InterfaceOperator.point_values)."""
        op = self.interface_post
        return op.point_values(self.x) if op is not None else None

    def interface_samples(self):
        """Samples of the interface fields for test tables."""
        from xfemcontact.post.checks import Samples

        v = self.interface_values()
        if v is None:
            return {}
        return {"interface": Samples(v["x"], v["y"], {k: v[k] for k in ("LAGS_C", "LAGS_F1", "gap", "slip")})}

    def displacement(self):
        return fields.nodal_displacement(self.layout, self.local_solution())

    def stresses(self):
        return fields.quadrature_stresses(self.mesh, self.geo, self.layout, self.D, self.local_solution())
