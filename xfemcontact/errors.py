"""Errors that reach the user as one line naming the file, key or group at fault."""


class XfcError(Exception):
    """Base class of every error we report to the user (exit code 2)."""

    exit_code = 2


class CaseError(XfcError):
    """A case file is wrong: ``file: key: what is wrong (what would be right)``."""


class MeshError(XfcError):
    """A mesh cannot be read or used."""


class FormulaError(XfcError):
    """A formula is refused or cannot be evaluated."""


class GeometryError(XfcError):
    """The level set cannot be handled (crack tip, degenerate cut)."""


class ConvergenceError(XfcError):
    """A nonlinear loop did not converge (exit code 3)."""

    exit_code = 3


def where(source, key):
    """Format the ``file: key`` prefix of a message."""
    return f"{source}: {key}" if key else f"{source}"
