"""``law = "contact"``: unilateral contact with Coulomb friction (DEFI_CONTACT).

LAGS_C and LAGS_F1 live on the vertices of the cut cells (the multiplier space
of :mod:`xfemcontact.contact.space`); the terms are code_aster's continuous
augmented-Lagrangian method (:mod:`xfemcontact.contact.gauss_point`), run by the
status and threshold loops of :mod:`xfemcontact.solver.loops` through
:class:`~xfemcontact.contact.gauss_problem.GaussContactProblem`.  Reads the ``[contact]``
table of the case.
"""
from xfemcontact.contact.laws.base import InterfaceLaw


class Contact(InterfaceLaw):
    name = "contact"
    doc = "unilateral contact, with Coulomb friction if [contact] frottement = COULOMB"
    multipliers = True
    case_tables = ("contact",)

    def multiplier_space(self, mesh, segments, points, case):
        from xfemcontact.contact import space

        return space.build(mesh, segments, case.contact.algo_lagr,
                           mesh.element.shape_linear(points.xi), points.w)

    def problem(self, setup):
        from xfemcontact.contact.gauss_problem import GaussContactProblem

        return GaussContactProblem(setup)


LAW = Contact()
