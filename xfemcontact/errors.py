"""Errors that reach the user as one line naming the file, key or group at fault.

Exit codes (``xfemcontact run``): 0 solved and every test OK, 1 some test NOOK,
2 bad input (:class:`XfcError` and its subclasses but :class:`ConvergenceError`),
3 no convergence (:class:`ConvergenceError`), 128 + signal number when
interrupted (:class:`Interrupted`: 130 for SIGINT / Ctrl-C, 143 for SIGTERM).

Under MPI an error is *collective* when every process raises it identically
(everything found while reading the case file, the output folder check, the
checks of :mod:`xfemcontact.preflight`, non-convergence): the command line then
reports it once and every process leaves with its exit code.  Any other error
(``collective = False``) may be raised by one process only: it is reported by
that process and the whole run is aborted (``MPI_Abort``) so that no process
waits forever for the others.
"""
from __future__ import annotations

from typing import Any


class XfcError(Exception):
    """Base class of every error we report to the user (exit code 2)."""

    exit_code = 2
    #: raised identically by every process (see the module documentation)
    collective = False

    def __init__(self, *args: object, collective: bool | None = None) -> None:
        super().__init__(*args)
        if collective is not None:
            self.collective = collective


class CaseError(XfcError):
    """A case file is wrong: ``file: key: what is wrong (what would be right)``."""

    collective = True


class MeshError(XfcError):
    """A mesh cannot be read or used."""


class FormulaError(XfcError):
    """A formula is refused or cannot be evaluated.

    Refusals at load time are collective; an evaluation error at the nodes of
    one process is not (the formula module marks it).
    """

    collective = True


class GeometryError(XfcError):
    """The level set cannot be handled (crack tip, degenerate cut)."""


class ConvergenceError(XfcError):
    """A nonlinear loop did not converge (exit code 3).

    ``diagnostics`` (a dict) is what results.json holds about the failure.
    """

    exit_code = 3
    collective = True

    def __init__(self, *args: object, diagnostics: dict[str, Any] | None = None,
                 collective: bool | None = None) -> None:
        super().__init__(*args, collective=collective)
        self.diagnostics: dict[str, Any] = diagnostics or {}


class Interrupted(BaseException):
    """SIGINT or SIGTERM received: the run stops cleanly (exit code 128 + signal).

    A BaseException, like KeyboardInterrupt, so that no ``except Exception``
    swallows it.  ``outcome`` is filled on the way up with what happened to the
    results ("previous results in X kept", "no results written", ...).
    """

    def __init__(self, signum: int, name: str | None = None) -> None:
        super().__init__(signum)
        self.signum = int(signum)
        self.name = name or _signal_name(signum)
        self.outcome: str | None = None

    @property
    def exit_code(self) -> int:
        return 128 + self.signum

    def __str__(self) -> str:
        return f"interrupted ({self.name}): {self.outcome or 'no results written'}"


def _signal_name(signum: int) -> str:
    import signal

    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


def where(source: str, key: str | None) -> str:
    """Format the ``file: key`` prefix of a message."""
    return f"{source}: {key}" if key else f"{source}"
