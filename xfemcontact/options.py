"""Our own command-line options: ``-xfc_<name> <value>``, declared once and checked like case keys.

Every option of the package is an :class:`Option` in :data:`OPTIONS`: its name
(without the ``-xfc_`` prefix), type, accepted values or range, default and
meaning.  :func:`get` reads one from the PETSc options database and checks it;
:func:`check_all` checks every ``-xfc_*`` option given (an unknown name or a
wrong value is one line naming the option and what it accepts, exit code 2), and
runs before anything heavy; :func:`help_lines` lists them for ``-help`` and
``xfemcontact run --help``.

    from xfemcontact import options
    unknown = options.get("friction_unknown", case.contact.friction_unknown)

PETSc is imported only when an option is read: the list can be printed before
PETSc starts.
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from typing import Any

from xfemcontact.errors import XfcError

PREFIX = "xfc_"
#: the checked value of an option: a string of ``choices`` or a float
Value = str | float


class OptionError(XfcError):
    """A ``-xfc_*`` option is unknown or has a wrong value (exit code 2, collective:
    every process reads the same options)."""

    collective = True


@dataclass(frozen=True)
class Option:
    """One ``-xfc_<name>`` option.

    ``type``: ``"choice"`` (a string matched case-insensitively against
    ``choices``, returned in their spelling) or ``"float"`` (finite, within
    ``gt``/``ge``/``le``).  ``default``: the value when the option is not given
    (None: the caller's, e.g. a case key); ``default_doc`` says where it comes
    from in the help.
    """

    name: str
    type: str
    doc: str
    choices: tuple[str, ...] = ()
    default: Value | None = None
    default_doc: str = ""
    gt: float | None = None
    ge: float | None = None
    le: float | None = None

    @property
    def flag(self) -> str:
        return f"-{PREFIX}{self.name}"

    def accepted(self) -> str:
        """The accepted values in words: ``"one of LAGS_F1, TRACTION"``, ``"a number > 0"``."""
        if self.type == "choice":
            return "one of " + ", ".join(self.choices)
        bounds = [f"{op} {limit:g}" for op, limit in ((">", self.gt), (">=", self.ge), ("<=", self.le))
                  if limit is not None]
        return "a number" + (" " + " and ".join(bounds) if bounds else "")

    def convert(self, text: str | None) -> Value:
        """The checked value of ``text``; :class:`OptionError` naming the option if wrong."""
        shown = " ".join(str(text).split())[:60] if text is not None else ""
        if text is None or not str(text).strip():
            raise OptionError(f"{self.flag}: needs a value ({self.accepted()})")
        text = str(text).strip()
        if self.type == "choice":
            folded = {c.casefold(): c for c in self.choices}
            if text.casefold() in folded:
                return folded[text.casefold()]
            raise OptionError(f"{self.flag} {_printable(shown)}: unknown value (expected "
                              f"{self.accepted()})")
        try:
            value = float(text)
        except ValueError:
            raise OptionError(f"{self.flag} {_printable(shown)}: not a number (expected "
                              f"{self.accepted()})") from None
        if (not math.isfinite(value) or (self.gt is not None and not value > self.gt)
                or (self.ge is not None and value < self.ge)
                or (self.le is not None and value > self.le)):
            raise OptionError(f"{self.flag} {_printable(shown)}: out of range (expected "
                              f"{self.accepted()})")
        return value


#: every -xfc_* option, by name (without the prefix)
OPTIONS = {o.name: o for o in (
    Option("friction_unknown", "choice",
           "friction dof: LAGS_F1 (code_aster's semi-multiplier) or TRACTION (the tangential "
           "traction: fewer factorisations); overrides the case's contact.friction_unknown",
           choices=("LAGS_F1", "TRACTION"), default_doc="the case's contact.friction_unknown"),
    Option("friction_newton", "choice",
           "how the Newton of integration = NOEUD treats Coulomb's law: COULOMB (a semi-smooth "
           "Newton on the whole law: the friction bound -mu LAGS_C of the iterate, contact and "
           "friction statuses updated at every Newton iteration) or TRESCA (the bound of the "
           "threshold loop, contact statuses in the status loop: the fixed point of earlier "
           "versions, slower)",
           choices=("COULOMB", "TRESCA"), default_doc="COULOMB"),
    Option("friction_line_search", "choice",
           "2-D, integration = NOEUD with Coulomb's law in Newton: MERIT (Newton's statuses from "
           "Alart and Curnier's augmented tests at the iterate, the friction bound from the "
           "augmented pressure, its steps damped by a non-monotone backtracking line search on "
           "the squared norm of the complementarity functions) or NONE (full steps, the bound "
           "mu |LAGS_C|, and the cycle guard: the method of earlier versions)",
           choices=("MERIT", "NONE"), default_doc="MERIT"),
    Option("coarse_start", "choice",
           "2-D, integration = NOEUD with the line search, algo_lagr = AUTO: where the sticking "
           "start breaks Coulomb's law (the interface slides or opens), STABLE solves the case "
           "in the stable multiplier space first and Newton starts from that answer (the answer "
           "is the rich space's); NONE starts Newton from the sticking start",
           choices=("STABLE", "NONE"), default_doc="STABLE"),
    Option("mesh_max_mb", "float",
           "largest amount of data (MB) a mesh file may declare (node coordinates, cells, "
           "fields, after decompression); larger files are refused before they are read",
           gt=0, le=1e9, default_doc="1/16 of this machine's memory"),
    Option("memory_limit", "float",
           "memory (MB) the case may use on all processes together; a case whose estimate "
           "does not fit is refused before the mesh is built; 0 switches the check off",
           ge=0, le=1e12, default_doc="what the machine, its cgroup and ulimit -v give"),
)}


def _database() -> Any:         # a petsc4py PETSc.Options (no type information)
    from xfemcontact._petsc import PETSc

    return PETSc.Options()


def given() -> dict[str, str]:
    """The ``-xfc_*`` options given: {name without prefix: value as text}."""
    return {key[len(PREFIX):]: value for key, value in _database().getAll().items()
            if key.startswith(PREFIX)}


def get(name: str, default: Value | None = None) -> Any:
    """The checked value of ``-xfc_<name>``, or ``default`` (then the option's own default)
    when it is not given.  Raises :class:`OptionError`.

    The value is a :data:`Value`: a ``str`` for ``"choice"`` options, a ``float`` for
    ``"float"`` ones (or None when neither given nor defaulted); typed ``Any`` since
    which one depends on ``name``."""
    option = OPTIONS[name]
    values = given()
    if name not in values:
        return default if default is not None else option.default
    return option.convert(values[name])


def check_all() -> None:
    """Check every ``-xfc_*`` option given: known name, accepted value (collective)."""
    for name, value in sorted(given().items()):
        if name not in OPTIONS:
            close = difflib.get_close_matches(name, list(OPTIONS), n=1, cutoff=0.5)
            hint = f"did you mean -{PREFIX}{close[0]}? " if close else ""
            known = ", ".join(o.flag for o in OPTIONS.values())
            raise OptionError(f"-{PREFIX}{_printable(name[:60])}: unknown option ({hint}known: "
                              f"{known})")
        OPTIONS[name].convert(value)


def help_lines() -> list[str]:
    """The options, one line each, as ``-help`` prints PETSc's."""
    lines = ["xfemcontact options:"]
    for o in OPTIONS.values():
        default = o.default if o.default is not None else o.default_doc
        lines.append(f"  {o.flag} <{default}>: {o.doc} ({o.accepted()})")
    return lines


def _printable(text: str) -> str:
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)
