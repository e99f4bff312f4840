"""``law = "contact"``: unilateral contact with Coulomb friction (DEFI_CONTACT).

LAGS_C and LAGS_F1 live on the vertices of the cut cells (the multiplier space
of :mod:`xfemcontact.contact.space`).  ``[contact] integration`` chooses the
formulation: ``NOEUD`` (default) writes the conditions at the multiplier dofs
and at the vertices whose values they extrapolate (:mod:`xfemcontact.contact.nodal`,
:class:`~xfemcontact.contact.nodal_problem.NodalContactProblem`), ``GAUSS`` is code_aster's continuous method at the
interface Gauss points (:mod:`xfemcontact.contact.gauss_point`,
:class:`~xfemcontact.contact.gauss_problem.GaussContactProblem`).  Both run the
status and threshold loops of :mod:`xfemcontact.solver.loops`.  Reads the
``[contact]`` table of the case.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from xfemcontact.contact.laws.base import InterfaceLaw

if TYPE_CHECKING:
    from xfemcontact.contact.problem import InterfaceProblem, InterfaceSetup
    from xfemcontact.contact.space import MultiplierSpace
    from xfemcontact.mesh.plex import LocalMesh
    from xfemcontact.xfem.geometry import Geometry
    from xfemcontact.xfem.integration import SegmentPoints
    from xfemcontact.xfem.integration3d import FacetPoints


class Contact(InterfaceLaw):
    """Unilateral contact with Coulomb friction, multipliers on the cut cells' vertices."""

    name = "contact"
    doc = "unilateral contact, with Coulomb friction if [contact] frottement = COULOMB"
    multipliers = True
    case_tables = ("contact",)
    frictional = True

    def multiplier_space(self, mesh: LocalMesh, geo: Geometry, points: SegmentPoints | FacetPoints,
                         case: Any) -> MultiplierSpace:
        from xfemcontact.contact import space

        if mesh.dim == 3:
            return space.build3d(mesh, points.cells, geo.phi, mesh.element.shape_linear(points.xi), points.w,
                                 case.contact.algo_lagr)
        return space.build(mesh, geo.segments(), case.contact.algo_lagr,
                           mesh.element.shape_linear(points.xi), points.w)

    def normal_only(self, case: Any) -> str | None:
        if case.contact.friction:
            return None
        return "contact without friction (contact.frottement = \"SANS\" or coulomb = 0)"

    def problem(self, setup: InterfaceSetup) -> InterfaceProblem:
        if setup.case.contact.integration == "GAUSS":
            from xfemcontact.contact.gauss_problem import GaussContactProblem

            return GaussContactProblem(setup)
        from xfemcontact.contact.nodal_problem import NodalContactProblem

        return NodalContactProblem(setup)


LAW = Contact()
