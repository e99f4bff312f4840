"""A case at one instant of its load history: every load evaluated at ``t``.

The history driver (:mod:`xfemcontact.history.loading`) assembles the loads of each
instant from it, and the coarse start of a history's first step
(:meth:`xfemcontact.model.Model.coarse_start`) builds its stable-space model from it.
"""
from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from xfemcontact.case.functions import TimeFormula
    from xfemcontact.case.load import Case


def case_at(case: Case, t: float) -> Case:
    """``case`` with its loads (imposed displacements, tractions, body force) at ``t``."""
    def comps(d: dict[str, TimeFormula]) -> dict[str, TimeFormula]:
        return {k: f.at(t) for k, f in d.items()}

    dirichlet = tuple(dataclasses.replace(d, components=comps(d.components)) for d in case.dirichlet)
    traction = tuple(dataclasses.replace(tr, force=None if tr.force is None else comps(tr.force),
                                         pressure=None if tr.pressure is None else tr.pressure.at(t))
                     for tr in case.traction)
    body = case.body_force
    if body is not None:
        body = dataclasses.replace(body, FX=body.FX.at(t), FY=body.FY.at(t),
                                   FZ=None if body.FZ is None else body.FZ.at(t))
    return dataclasses.replace(case, dirichlet=dirichlet, traction=traction, body_force=body)
