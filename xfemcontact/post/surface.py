"""The interface surface of a 3-D run: its curved facets with the interface fields.

The interface of a 3-D cut is made of curved TRIA6 facets (:mod:`xfemcontact.xfem.cut3d`:
the facets of the cut cells, and the cell faces lying on the interface), each a map
of its six nodes in the parent cell's reference coordinates.  This module evaluates
the interface fields of the interface problem at those nodes
(:meth:`~xfemcontact.contact.problem.InterfaceProblem.surface_values`) and makes a
mesh of them: one ``triangle6`` cell per facet, the nodes shared by neighbouring
facets merged by position (:func:`~xfemcontact.post.points.merge_points`), so
ParaView draws one connected surface with continuous fields.

Point fields (at the facets' nodes): LAGS_C (Pa), LAGS_F1, LAGS_F2 (-), T (Pa, the
magnitude of the tangential traction, basis-free), gap, slip1, slip2, slip (m: [u].n,
[u].t1, [u].t2 and the magnitude of the tangential jump), contact (1 contact / 0
open), sliding (1 slip / 0 stick), DX, DY, DZ and ``displacement`` (m: the mean of
the two sides, (u(+) + u(-)) / 2, for *Warp By Vector*), ``normal`` (the unit normal
from the LN < 0 side to the LN > 0 side), ``t1``, ``t2`` (the tangent basis of
LAGS_F1, LAGS_F2, slip1, slip2).  Cell field: ``cell``, the input cell index.

The value at a merged node is the one of the facet of the lowest input cell
(multipliers and jumps are continuous; the normal, a gradient of the P2 level set,
may differ by the discretisation between cells), so the file does not depend on
the number of processes.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from xfemcontact.contact.problem import SURFACE_FIELDS
from xfemcontact.post.fields import displacement_at
from xfemcontact.post.points import merge_points

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.model import Model

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    #: arrays by name, one row per facet
    Columns = dict[str, NDArray[Any]]

#: the vector fields of the surface (besides ``displacement``)
VECTORS = ("normal", "t1", "t2")


def facet_nodes(model: Model) -> tuple[FloatArray, NDArray[np.bool_]]:
    """The parent reference coordinates ``(k, nf, 6, 3)`` of the TRIA6 nodes of the facets of
    every interface cell, rows as ``model.problem.points`` (cut cells, then the cells owning an
    interface face), padded to the largest facet count with the cell's centre, and which
    facets are live ``(k, nf)``."""
    geo, el = model.geo, model.mesh.element
    assert geo is not None                      # an interface
    parts = [f for f in (geo.facets, geo.face_facets) if f is not None and len(f)]
    if not parts:
        return np.zeros((0, 1, 6, 3)), np.zeros((0, 1), bool)
    nf = max(f.nodes.shape[1] for f in parts)
    centre = el.ref_nodes[: el.nv].mean(axis=0)
    nodes = np.concatenate([np.concatenate([f.nodes, np.broadcast_to(centre, (len(f), nf - f.nodes.shape[1], 6, 3))],
                                           axis=1) for f in parts])
    live = np.concatenate([np.pad(f.live, ((0, 0), (0, nf - f.live.shape[1]))) for f in parts])
    nodes = np.where(live[..., None, None], nodes, centre)
    return nodes, live


def local_pieces(model: Model, xl: FloatArray) -> Columns | None:
    """The live facets of this process with their fields at their nodes (None: not a 3-D
    run with an interface problem).  Collective (the fields read remote dofs).

    ``xl``: the local work array of the solution (``model.local_solution()``).  Returns
    ``cell (m,)`` input ids, ``facet (m,)`` the facet's index in its cell, ``x (m, 6, 3)``
    (m), ``u (m, 6, 3)`` (m, the mean of the two sides), each of SURFACE_FIELDS ``(m, 6)``
    and VECTORS ``(m, 6, 3)``.
    """
    mesh, problem = model.mesh, model.problem
    if mesh.dim != 3 or problem is None or model.geo is None:
        return None
    nodes, live = facet_nodes(model)
    cells = problem.points.cells
    assert len(cells) == len(nodes)             # the rows of the interface problem
    k, nf = live.shape
    xi = nodes.reshape(k, nf * 6, 3)
    values = problem.surface_values(model.x, xi)
    ones = np.ones(k)
    u = 0.5 * (displacement_at(model, xl, cells, xi, ones) + displacement_at(model, xl, cells, xi, -ones))
    x = mesh.element.map_points(mesh.x[mesh.cell_nodes[cells]], xi)
    row, facet = np.nonzero(live)

    def per_facet(a: NDArray[Any]) -> NDArray[Any]:
        return a.reshape((k, nf, 6) + a.shape[2:])[row, facet]

    out: Columns = {"cell": mesh.cell_ids[cells][row], "facet": facet, "x": per_facet(x), "u": per_facet(u)}
    out.update({name: per_facet(values[name]) for name in SURFACE_FIELDS + VECTORS})
    return out


def samples(pieces: Columns) -> Columns:
    """The pieces' node values as flat samples (x, y, z, cell, LAGS_C, LAGS_F1, LAGS_F2,
    contact, sliding) for the interface points of the post-processing mesh
    (:func:`~xfemcontact.post.postmesh.assemble`)."""
    x = pieces["x"].reshape(-1, 3)
    out = {"x": x[:, 0], "y": x[:, 1], "z": x[:, 2], "cell": np.repeat(pieces["cell"], 6)}
    out.update({name: pieces[name].ravel() for name in ("LAGS_C", "LAGS_F1", "LAGS_F2", "contact", "sliding")})
    return out


def assemble(pieces: Columns) -> tuple[FloatArray, list[tuple[str, IntArray]], Columns, dict[str, list[IntArray]]]:
    """The interface surface mesh of the gathered ``pieces`` (:func:`local_pieces` of every
    process), as the points ``(np, 3)``, the block of ``triangle6`` cells, the point data and
    the cell data of a :class:`~xfemcontact.post.postmesh.PostMesh`: facets ordered by
    (input cell, facet), nodes merged by position and numbered by first use, the values of
    the first facet holding a node."""
    order = np.lexsort((pieces["facet"], pieces["cell"]))
    p = {key: a[order] for key, a in pieces.items()}
    m = len(order)
    xs = p["x"].reshape(-1, 3)
    label = merge_points(xs)                                 # numbered by first appearance
    _, first = np.unique(label, return_index=True)
    conn = label.reshape(m, 6).astype(np.int64)
    pd: dict[str, NDArray[Any]] = {name: p[name].ravel()[first] for name in SURFACE_FIELDS}
    u = p["u"].reshape(-1, 3)[first]
    pd.update({"DX": u[:, 0], "DY": u[:, 1], "DZ": u[:, 2]})
    pd.update({name: p[name].reshape(-1, 3)[first] for name in VECTORS})
    return xs[first], [("triangle6", conn)], pd, {"cell": [p["cell"].astype(np.int64)]}
