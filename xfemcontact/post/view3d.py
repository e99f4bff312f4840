"""Pictures of 3-D surfaces with matplotlib's 2-D artists: a view, the painter's order, an image.

A view (:func:`view`) is a camera direction (elevation and azimuth in degrees, as
matplotlib's 3-D axes name them) and the screen axes it gives.  Surfaces are lists of
polygons (triangles or quadrangles) carrying one value each; projected on the screen
and drawn far to near (the painter's algorithm: each polygon covers what it hides), as
polygons with their edges when there are few of them (:data:`VECTOR_POLYGONS`), else
into an image of :data:`PIXELS` (every pixel the value of the nearest polygon over its
centre, :func:`~xfemcontact.post.drawing.rasterise`): no more than the picture can show,
at a cost that grows with the pixels, not with the mesh.  NumPy only: the figures are
drawn from what these functions return (:mod:`xfemcontact.post.plots3d`).
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from xfemcontact.post.drawing import rasterise

if TYPE_CHECKING:
    from numpy.typing import NDArray

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]

#: up to this many polygons a view is drawn as polygons with edges; above, as an image
VECTOR_POLYGONS = 4000
#: long side of the image of a view, pixels
PIXELS = 500
#: triangles are widened by this many pixels in the image (:func:`_widened`)
WIDEN = 0.75


def view(elev: float, azim: float) -> FloatArray:
    """The view matrix ``(3, 3)``: rows the screen's right and up directions and the
    direction towards the camera (unit vectors; elevation and azimuth in degrees)."""
    e, a = np.radians(elev), np.radians(azim)
    towards = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    right = np.array([-np.sin(a), np.cos(a), 0.0])
    return np.stack([right, np.cross(towards, right), towards])


def project(points: FloatArray, R: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Screen coordinates ``(n, 2)`` and depths ``(n,)`` (larger: nearer the camera) of
    ``points (n, 3)`` in the view ``R``."""
    q = points @ R.T
    return q[:, :2], q[:, 2]


def picture(points: FloatArray, polygons: IntArray, values: FloatArray, R: FloatArray,
            edges: bool = True) -> dict[str, Any]:
    """What a view shows of the polygons ``polygons (m, c)`` (indices of ``points (n, 3)``,
    c = 3 or 4) with one value each ``values (m,)``, in the view ``R``.

    Returns ``{"polygons": (m, c, 2) screen coordinates far to near, "values", "edges"}``
    for few polygons, else ``{"image": (H, W) float32, NaN where nothing is drawn,
    "extent"}``; both with ``"xlim"``, ``"ylim"``."""
    return paint(layout(points, polygons, R, edges), values)


def layout(points: FloatArray, polygons: IntArray, R: FloatArray, edges: bool = True) -> dict[str, Any]:
    """The geometry of a :func:`picture`, to :func:`paint` with one field or several: the
    polygons far to near (``order``) and, above :data:`VECTOR_POLYGONS`, the image of which
    polygon each pixel shows (``label``, -1 for none)."""
    xy, depth = project(points, R)
    order = np.argsort(depth[polygons].mean(axis=1), kind="stable")          # far first
    poly = polygons[order]
    lo, hi = (xy.min(axis=0), xy.max(axis=0)) if len(xy) else (np.zeros(2), np.ones(2))
    pad = 0.03 * max(float((hi - lo).max()), 1e-300)
    out: dict[str, Any] = {"xlim": (lo[0] - pad, hi[0] + pad), "ylim": (lo[1] - pad, hi[1] + pad),
                           "order": order}
    if len(poly) <= VECTOR_POLYGONS:
        out.update({"polygons": xy[poly], "edges": edges})
        return out
    span = np.maximum(hi - lo, 1e-300)
    px = float(span.max()) / PIXELS
    W, H = (np.ceil(span / px).astype(int) + 1).tolist()
    tri = poly[:, [0, 1, 2]]
    label = np.arange(len(poly))
    if poly.shape[1] == 4:                         # quadrangles: two triangles each
        tri = np.concatenate([tri, poly[:, [0, 2, 3]]])
        label = np.r_[label, label]
        keep = np.argsort(np.r_[np.arange(len(poly)), np.arange(len(poly))], kind="stable")
        tri, label = tri[keep], label[keep]        # still far to near
    out.update({"label": rasterise(_widened((xy[tri] - lo) / px), label, W, H),
                "extent": (lo[0] - 0.5 * px, lo[0] + (W - 0.5) * px, lo[1] - 0.5 * px, lo[1] + (H - 0.5) * px)})
    return out


def paint(geometry: dict[str, Any], values: FloatArray) -> dict[str, Any]:
    """The :func:`picture` of the :func:`layout` ``geometry`` with the polygons' ``values (m,)``."""
    vals = values[geometry["order"]]
    out = {k: v for k, v in geometry.items() if k not in ("order", "label")}
    if "label" not in geometry:
        out["values"] = vals
        return out
    lab = geometry["label"]
    img = np.full(lab.shape, np.nan, np.float32)
    img[lab >= 0] = vals[lab[lab >= 0]]
    out["image"] = img
    return out


def _widened(tri: FloatArray, pixels: float = WIDEN) -> FloatArray:
    """Triangles ``(t, 3, 2)`` (pixel units) with each vertex moved ``pixels`` away from
    the triangle's centre: the pixels along shared edges, and along the hairline cracks
    between the curved facets of two cells (whose mid-nodes need not agree), are covered
    by the nearer triangle instead of showing what lies behind."""
    c = tri.mean(axis=1, keepdims=True)
    d = tri - c
    r = np.linalg.norm(d, axis=-1, keepdims=True)
    return c + d * (1.0 + pixels / np.where(r > 0, r, 1.0))


def draw(ax: Any, pic: dict[str, Any], cmap: Any, norm: Any) -> None:
    """Draw a :func:`picture` ``pic`` on the matplotlib axes ``ax`` with the colour map and
    normalisation given (values outside the norm take the map's ends)."""
    from matplotlib.collections import PolyCollection

    if "image" in pic:
        img = pic["image"]
        rgba = cmap(norm(np.nan_to_num(img, nan=norm.vmin)))
        rgba[np.isnan(img), 3] = 0.0
        ax.imshow(rgba, origin="lower", interpolation="nearest", extent=pic["extent"])
    else:
        pc = PolyCollection(list(pic["polygons"]), cmap=cmap, norm=norm,
                            edgecolors="0.3" if pic["edges"] else "face", linewidths=0.2)
        pc.set_array(pic["values"])
        ax.add_collection(pc)
    ax.set_xlim(*pic["xlim"])
    ax.set_ylim(*pic["ylim"])
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def triad(ax: Any, R: FloatArray) -> None:
    """The x, y, z axes of the view ``R`` as three short arrows in the lower left corner."""
    for i, name in enumerate("xyz"):
        d = R[:2, i] * 0.06
        ax.annotate("", xy=(0.1 + d[0], 0.1 + d[1]), xytext=(0.1, 0.1), xycoords="axes fraction",
                    arrowprops={"arrowstyle": "->", "lw": 1.0, "color": "0.2"})
        ax.text(0.1 + 1.4 * d[0], 0.1 + 1.4 * d[1], name, transform=ax.transAxes, fontsize=8,
                ha="center", va="center")
