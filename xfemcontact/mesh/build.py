"""The case's input mesh on rank 0: read or generated, then refined."""
from __future__ import annotations

from typing import TYPE_CHECKING

from xfemcontact._petsc import PETSc

if TYPE_CHECKING:
    from xfemcontact.case.load import Case
    from xfemcontact.mesh.raw import RawMesh


def build_raw_mesh(case: Case) -> RawMesh | None:
    """The :class:`~xfemcontact.mesh.raw.RawMesh` of ``case`` on rank 0 (read from
    ``mesh.file`` or generated from ``mesh.rectangle``, refined ``mesh.refine``
    times); None on the other processes."""
    if PETSc.COMM_WORLD.rank != 0:
        return None
    from xfemcontact.mesh.generate import rectangle
    from xfemcontact.mesh.read import read_mesh
    from xfemcontact.mesh.refine import refine_uniform

    spec = case.mesh
    if spec.file:
        # the data a mesh file refers to stays with the case or the mesh file
        roots = [case.path.parent, spec.file.parent]
        raw = read_mesh(spec.file, display_name=spec.file.name, roots=roots)
    else:
        assert spec.rectangle is not None        # the case gives a mesh file or a rectangle
        raw = rectangle(**spec.rectangle)
    if spec.refine:
        raw = refine_uniform(raw, spec.refine)
    return raw
