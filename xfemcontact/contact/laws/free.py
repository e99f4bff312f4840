"""``law = "free"``: traction-free lips.

The interface transmits nothing: no unknowns, no terms.  Each side is a
separate body for the rigid-body check of :mod:`xfemcontact.preflight`; the
results report the gap and slip at the interface points (the lips may
interpenetrate: nothing prevents it).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from xfemcontact.contact.laws.base import InterfaceLaw

if TYPE_CHECKING:
    from xfemcontact.contact.problem import InterfaceProblem, InterfaceSetup


class Free(InterfaceLaw):
    """Traction-free lips: no unknowns, separate bodies."""

    name = "free"
    doc = "traction-free lips (nothing crosses the interface)"
    separate_bodies = True

    def problem(self, setup: InterfaceSetup) -> InterfaceProblem:
        from xfemcontact.contact.problem import InterfaceProblem

        return InterfaceProblem(setup, bonded=False)


LAW = Free()
