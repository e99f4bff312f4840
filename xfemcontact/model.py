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
from xfemcontact.dofs import constraints
from xfemcontact.dofs.layout import DofLayout
from xfemcontact.errors import MeshError
from xfemcontact.fem.elasticity import hooke
from xfemcontact.mesh import plex
from xfemcontact.post import fields
from xfemcontact.solver.newton import create_snes
from xfemcontact.timing import phase
from xfemcontact.xfem import geometry, levelset


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
            self.mesh = plex.load(raw, self.comm)
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
            raise MeshError(f"{self.case.source}: interface.level_set_field: reading nodal fields "
                            f"from mesh files is not available yet; give interface.level_set")
        phi = levelset.nodal_values(mesh, itf, field)
        return geometry.build(mesh, phi)

    def _layout(self):
        mesh, geo = self.mesh, self.geo
        x = mesh.x
        fixed, values = constraints.fixed_components(
            mesh, self.case, geo, lambda nodes, f: f(x=x[nodes, 0], y=x[nodes, 1]))
        enriched = geo.enriched if geo is not None else np.zeros(len(x), bool)
        multiplier = np.zeros(len(x), bool)
        self.fixed, self.values = fixed, values
        self.layout = DofLayout(mesh, enriched, multiplier, fixed)
        self.x_bc = system.bc_array(self.layout, fixed, values)

    def _couplings(self):
        """Point lists of every element coupling (for the matrix pattern)."""
        return [self.mesh.cell_nodes]

    def _assemble(self):
        mesh, geo, layout = self.mesh, self.geo, self.layout
        self.K = pattern.create_matrix(layout, self._couplings())
        lift = layout.local_array()
        system.assemble_bulk(mesh, geo, layout, self.D, self.K, lift, self.x_bc)
        self.K.assemble()
        f_ext = layout.local_array()
        if self.case.body_force is not None:
            system.add_body_forces(mesh, geo, layout, self.case.body_force, f_ext)
        system.add_tractions(mesh, geo, layout, self.case.traction, f_ext)
        self.f0 = system.local_to_global(layout, lift - f_ext)
        self.load_norm = self.f0.norm()

    # -- solve --------------------------------------------------------------
    def residual(self, snes, x, f):
        self.K.mult(x, f)
        f.axpy(1.0, self.f0)

    def jacobian(self, snes, x, J, P):
        pass

    def solve(self):
        """Newton on the bulk problem; returns the SNES converged reason."""
        newton = self.case.newton
        f = self.layout.create_global_vec()
        self.snes, self.newton_test = create_snes(
            self.comm, self.residual, self.jacobian, self.K, f,
            newton.resi_glob_rela, newton.iter_glob_maxi, lambda: self.load_norm)
        with phase("solve"):
            self.snes.solve(None, self.x)
        return self.snes.getConvergedReason()

    # -- results ------------------------------------------------------------
    def local_solution(self):
        """Local work array of the solution, imposed values included."""
        return system.global_to_local(self.layout, self.x, self.x_bc)

    def displacement(self):
        return fields.nodal_displacement(self.layout, self.local_solution())

    def stresses(self):
        return fields.quadrature_stresses(self.mesh, self.geo, self.layout, self.D, self.local_solution())
