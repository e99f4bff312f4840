"""``law = "bonded"``: the sides stay glued (zero jump).

Every Heaviside dof is fixed (:mod:`xfemcontact.dofs.constraints`), so the
interface carries no unknowns and adds no terms; the results still report gap
and slip (zero) at the interface points.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from xfemcontact.contact.laws.base import InterfaceLaw

if TYPE_CHECKING:
    from xfemcontact.contact.problem import InterfaceProblem, InterfaceSetup


class Bonded(InterfaceLaw):
    """The sides glued: zero jump, no unknowns."""

    name = "bonded"
    doc = "the sides stay glued (zero jump)"
    zero_jump = True

    def problem(self, setup: InterfaceSetup) -> InterfaceProblem:
        from xfemcontact.contact.problem import InterfaceProblem

        return InterfaceProblem(setup, bonded=True)


LAW = Bonded()
