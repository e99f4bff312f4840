"""``law = "bonded"``: the sides stay glued (zero jump).

Every Heaviside dof is fixed (:mod:`xfemcontact.dofs.constraints`), so the
interface carries no unknowns and adds no terms; the results still report gap
and slip (zero) at the interface points.
"""
from xfemcontact.contact.laws.base import InterfaceLaw


class Bonded(InterfaceLaw):
    name = "bonded"
    doc = "the sides stay glued (zero jump)"
    zero_jump = True

    def problem(self, setup):
        from xfemcontact.contact.problem import InterfaceProblem

        return InterfaceProblem(setup, bonded=True)


LAW = Bonded()
