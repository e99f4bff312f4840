"""Interface laws, one module each, found by name (``[interface] law`` of a case).

    from xfemcontact.contact import laws
    law = laws.get("contact")         # an InterfaceLaw (see laws.base)

Adding a law: a module here defining ``LAW`` (an
:class:`~xfemcontact.contact.laws.base.InterfaceLaw`), listed in ``_MODULES``,
with its tests; nothing else compares law names.
"""
from xfemcontact.contact.laws import bonded, contact, free, glissiere
from xfemcontact.contact.laws.base import InterfaceLaw

_MODULES = (contact, bonded, free, glissiere)
_LAWS = {m.LAW.name: m.LAW for m in _MODULES}
#: the law names, the first being the default
NAMES: tuple[str, ...] = tuple(_LAWS)


def get(name: str) -> InterfaceLaw:
    """The law called ``name`` (KeyError for an unknown name: the case loader
    has refused those already)."""
    return _LAWS[name]


__all__ = ["InterfaceLaw", "NAMES", "get"]
