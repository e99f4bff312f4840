"""Drawing helpers shared by the 2-D and 3-D plots (:mod:`xfemcontact.post.plots`,
:mod:`xfemcontact.post.plots3d`, :mod:`xfemcontact.post.view3d`): figures with fixed
margins, colour ranges, and triangles drawn into a label image (NumPy only)."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from numpy.typing import ArrayLike, NDArray

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]


def figure(w: float, h: float, **margins: float) -> Figure:
    """A figure of ``w`` x ``h`` inches with fixed margins (``subplots_adjust``
    arguments, fractions of the figure): matplotlib's constrained layout measured
    every tick label twice and took half of the drawing time."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(w, h), dpi=110)
    fig.subplots_adjust(**margins)
    return fig


def plain_log_labels(ax: Axes) -> None:
    """Tick labels of a log-scaled y axis as plain text (``1e-05``): the default ones
    are mathtext (``$10^{-5}$``), whose parser took 0.15 s of a 0.2 s figure."""
    from matplotlib.ticker import LogFormatter

    ax.yaxis.set_major_formatter(LogFormatter())
    ax.yaxis.set_minor_formatter(LogFormatter(labelOnlyBase=False))


def rasterise(tri: FloatArray, label: IntArray, W: int, H: int, chunk: int = 1 << 21) -> IntArray:
    """Label image ``(H, W)`` of triangles ``tri (T, 3, 2)`` given in pixel units
    (pixel ``(i, j)`` has its centre at ``(i, j)``): every pixel whose centre lies
    in triangle ``t`` gets ``label[t]`` (a later triangle wins), -1 elsewhere.

    Each triangle's three edge functions ``w = a x + b y + c`` (positive inside for
    a counter-clockwise triangle) are tested at the pixel centres of its bounding
    box, ``chunk`` candidate pixels at a time."""
    img = np.full((H, W), -1, np.int64)
    x, y = tri[..., 0], tri[..., 1]
    area: FloatArray = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    sgn = np.where(area < 0, -1.0, 1.0)
    coef = []
    for i, j in ((0, 1), (1, 2), (2, 0)):                    # edge i -> j, inside on its left
        a = -(y[:, j] - y[:, i]) * sgn
        b = (x[:, j] - x[:, i]) * sgn
        coef.append((a, b, -(a * x[:, i] + b * y[:, i])))
    x0 = np.clip(np.ceil(np.minimum(np.minimum(x[:, 0], x[:, 1]), x[:, 2])), 0, W).astype(np.int64)
    x1 = np.clip(np.floor(np.maximum(np.maximum(x[:, 0], x[:, 1]), x[:, 2])), -1, W - 1).astype(np.int64)
    y0 = np.clip(np.ceil(np.minimum(np.minimum(y[:, 0], y[:, 1]), y[:, 2])), 0, H).astype(np.int64)
    y1 = np.clip(np.floor(np.maximum(np.maximum(y[:, 0], y[:, 1]), y[:, 2])), -1, H - 1).astype(np.int64)
    nx, ny = np.maximum(x1 - x0 + 1, 0), np.maximum(y1 - y0 + 1, 0)
    count = nx * ny
    keep = np.nonzero(count)[0]
    ends = np.cumsum(count[keep])
    first = 0
    while first < len(keep):
        base = ends[first - 1] if first else 0
        last = max(int(np.searchsorted(ends, base + chunk, side="right")), first + 1)
        t = keep[first:last]
        c = count[t]
        tt = np.repeat(t, c)
        k = np.arange(int(c.sum())) - np.repeat(np.cumsum(c) - c, c)
        nxt = nx[tt]
        ix = x0[tt] + k % nxt
        iy = y0[tt] + k // nxt
        inside = np.ones(len(tt), bool)
        for a, b, d in coef:
            inside &= a[tt] * ix + b[tt] * iy + d[tt] >= 0
        img[iy[inside], ix[inside]] = label[tt[inside]]
        first = last
    return img


def colour_limits(v: ArrayLike, scale: float = 0.0) -> tuple[float, float]:
    """Data range, widened to +-1e-3 max(|mean|, scale) around the mean when the field
    is nearly uniform (so round-off does not paint a uniform field in every colour)."""
    lo, hi = float(np.min(v)), float(np.max(v))
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    floor = 1e-3 * max(abs(mid), scale, 1e-300)
    if half < floor:
        half = floor if mid != 0 else 1.0
    return mid - half, mid + half
