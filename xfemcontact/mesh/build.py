"""The case's input mesh on rank 0: read or generated, then refined."""
from __future__ import annotations

from typing import TYPE_CHECKING

from xfemcontact._petsc import PETSc

if TYPE_CHECKING:
    from xfemcontact.case.load import Case
    from xfemcontact.mesh.raw import RawMesh


def build_raw_mesh(case: Case) -> RawMesh | None:
    """The :class:`~xfemcontact.mesh.raw.RawMesh` of ``case`` on rank 0 (read from
    ``mesh.file`` or generated from ``mesh.rectangle`` or ``mesh.box``, refined
    ``mesh.refine`` times); None on the other processes."""
    if PETSc.COMM_WORLD.rank != 0:
        return None
    from xfemcontact.errors import MeshError
    from xfemcontact.mesh.generate import box, rectangle
    from xfemcontact.mesh.read import read_mesh
    from xfemcontact.mesh.refine import refine_uniform

    spec = case.mesh
    if spec.file:
        # the data a mesh file refers to stays with the case or the mesh file
        roots = [case.path.parent, spec.file.parent]
        raw = read_mesh(spec.file, display_name=spec.file.name, roots=roots)
    elif spec.box is not None:
        raw = box(**spec.box)
    else:
        assert spec.rectangle is not None        # the case gives a mesh file, a rectangle or a box
        raw = rectangle(**spec.rectangle)
    if raw.dim != case.dim:
        wanted = '"3D"' if raw.dim == 3 else '"C_PLAN" or "D_PLAN"'
        raise MeshError(f"{raw.source}: {raw.cell_type} cells are {raw.dim}-D but material.model = "
                        f"\"{case.material.model}\" is {case.dim}-D (use model = {wanted})")
    if spec.refine:
        raw = refine_uniform(raw, spec.refine)
    return raw
