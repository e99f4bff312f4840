"""Point coordinates as the keyword arguments of case formulas.

    f(**coordinates(points))      # f(x=..., y=...) in 2-D, f(x=..., y=..., z=...) in 3-D
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]

#: the names of the coordinates, in order
NAMES = ("x", "y", "z")


def coordinates(x: FloatArray) -> dict[str, FloatArray]:
    """The keyword arguments giving a formula the coordinates ``x (..., d)`` of points
    (m): ``x``, ``y`` and, in 3-D, ``z``."""
    return {name: x[..., i] for i, name in enumerate(NAMES[:x.shape[-1]])}
