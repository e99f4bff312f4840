"""``law = "glissiere"``: bilateral sliding, code_aster's GLISSIERE = 'OUI' (DEFI_CONTACT).

Unilateral contact whose contact, once made, is kept: a multiplier dof (or, with
``integration = "GAUSS"``, a Gauss point) that enters contact stays in contact, so
the sides then move together along the normal -- in tension as in compression,
LAGS_C of either sign -- and slide freely along the interface (frictionless).
Before contact the sides are free to open, as with ``law = "contact"``; with
``[contact] contact_init = "OUI"`` (the default) every dof starts in contact, hence
bilateral from the start.  The memory carries over the load steps of a case with
``[instants]`` (the contact statuses do): code_aster's SSNV201, a block opened, then
closed, then pulled and sheared, keeps its interface closed when pulled.

Reads the ``[contact]`` table (coef_cont, contact_init, integration, iter_cont_maxi,
algo_lagr); frictionless: ``frottement = "COULOMB"`` is refused when the case is read.
The multipliers, space, operator and loops are those of ``law = "contact"``
(:mod:`xfemcontact.contact.laws.contact`): its problem with ``bilateral`` set, which
keeps the contact statuses from going 1 -> 0 and accepts tension at the dependent
vertices (:class:`~xfemcontact.contact.nodal_problem.NodalContactProblem`,
:class:`~xfemcontact.contact.gauss_problem.GaussContactProblem`).  The status loop
then ends: statuses only go 0 -> 1.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from xfemcontact.contact.laws.contact import Contact

if TYPE_CHECKING:
    from xfemcontact.contact.problem import InterfaceProblem, InterfaceSetup


class Glissiere(Contact):
    """Bilateral sliding: contact once made is kept, no friction."""

    name = "glissiere"
    doc = "bilateral sliding (code_aster's GLISSIERE): contact once made is kept, frictionless"
    frictional = False

    def normal_only(self, case: Any) -> str | None:
        return "law = \"glissiere\" (frictionless)"

    def problem(self, setup: InterfaceSetup) -> InterfaceProblem:
        problem = super().problem(setup)
        problem.bilateral = True
        return problem


LAW = Glissiere()
