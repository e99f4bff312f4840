"""What every interface law declares, and the default answers.

A law is an object with a few facts the rest of the package asks about
(instead of comparing names) and a factory of its
:class:`~xfemcontact.contact.problem.InterfaceProblem`:

* ``multipliers``: LAGS_C / LAGS_F1 dofs on the vertices of cut cells (the
  multiplier space of :mod:`xfemcontact.contact.space`);
* ``zero_jump``: every Heaviside dof is fixed (the sides move together);
* ``separate_bodies``: the two sides are separate bodies for the rigid-body
  check of :mod:`xfemcontact.preflight` (nothing crosses the interface);
* ``case_tables``: the case tables it reads besides ``[interface]``;
* ``frictional``: it takes Coulomb friction (``[contact] frottement = "COULOMB"``;
  a frictionless law refuses it when the case is read);
* ``problem(setup)``: the interface problem the solver and the
  post-processing use;
* ``normal_only(case)``: whether, for ``case``, it transmits normal forces only (no
  friction): then a side held by nothing else must be held by the normals alone
  (:func:`xfemcontact.rigid.held_through_normals`).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from xfemcontact.contact.problem import InterfaceProblem, InterfaceSetup
    from xfemcontact.contact.space import MultiplierSpace
    from xfemcontact.mesh.plex import LocalMesh
    from xfemcontact.xfem.geometry import Geometry
    from xfemcontact.xfem.integration import SegmentPoints
    from xfemcontact.xfem.integration3d import FacetPoints


class InterfaceLaw:
    """Base of the interface laws (see the module documentation)."""

    name: str = ""
    doc: str = ""
    multipliers: bool = False
    zero_jump: bool = False
    separate_bodies: bool = False
    case_tables: tuple[str, ...] = ()
    frictional: bool = False

    def multiplier_space(self, mesh: LocalMesh, geo: Geometry, points: SegmentPoints | FacetPoints,
                         case: Any) -> MultiplierSpace | None:
        """The multiplier space of the interface (None: no multipliers).

        ``points``: the Gauss points of the interface of ``geo`` (2-D: of
        ``geo.segments()``; 3-D: of its facets, cut cells then interface faces); ``case``: the
        :class:`~xfemcontact.case.load.Case` (not imported: the case package
        imports the laws)."""
        return None

    def problem(self, setup: InterfaceSetup) -> InterfaceProblem:
        """The :class:`~xfemcontact.contact.problem.InterfaceProblem` of the interface
        for ``setup`` (a :class:`~xfemcontact.contact.problem.InterfaceSetup`)."""
        raise NotImplementedError

    def normal_only(self, case: Any) -> str | None:
        """How ``case`` makes the interface transmit normal forces only, in the words of
        the case file (for messages), or None when it transmits tangential ones too or
        none at all."""
        return None

    def __repr__(self) -> str:
        return f"<interface law {self.name!r}>"
