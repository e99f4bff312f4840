"""Read a quadratic 2-D mesh file into a checked :class:`RawMesh` (through meshio).

Supported files: MED (``.med``, ``.mmed``), Gmsh (``.msh``), XDMF (``.xdmf``,
``.xmf``) and VTU (``.vtu``).  The mesh must hold exactly one 2-D quadratic cell
type: meshio ``quad8`` (our QUAD8) or ``triangle6`` (our TRIA6); several blocks
of it are concatenated in file order.  ``line3`` blocks become edge groups
(rows ``(a, b, mid)``) and ``vertex`` blocks node groups; a block that belongs
to no group is dropped.  Node numbering is kept as in the file, unused nodes
included.  Coordinates are taken in the file's unit (m for our cases).

Where the group names come from:

* MED: ``cell_data["cell_tags"]`` + ``mesh.cell_tags`` {family: [groups]} and
  ``point_data["point_tags"]`` + ``mesh.point_tags``; a family may carry
  several groups, and a group gets the entities of every family listing it.
* Gmsh: ``cell_data["gmsh:physical"]`` + ``field_data`` {name: [tag, dim]}
  (a physical group without a name is called by its tag), and the
  ``cell_sets`` that meshio builds from the entities of MSH 4.1 files.
* XDMF / VTU: ``cell_sets`` / ``point_sets`` when present, else integer
  cell / point data in the layout meshio's ``cell_sets_to_data()`` writes
  (what meshio 5.0's VTU writer turns ``cell_sets`` into): the key is the set
  names joined by ``-`` and the value of a cell is the index of its set in that
  list, ``-1`` for none.  Such data hold one set per cell (overlapping sets are
  lost when written) and meshio 5.0 writes XDMF without any sets, so groups
  given through these formats must be disjoint cell sets; node groups are best
  given as ``vertex`` cells in those sets.

Every failure is a one-line :class:`MeshError` naming the file.
"""
import importlib
import os

import numpy as np

from xfemcontact.errors import MeshError
from xfemcontact.mesh.raw import RawMesh

#: file extension -> meshio format name
FORMATS = {".med": "med", ".mmed": "med", ".msh": "gmsh",
           ".xdmf": "xdmf", ".xmf": "xdmf", ".vtu": "vtu"}
_FORMAT_NAMES = {"med": "MED", "gmsh": "Gmsh", "xdmf": "XDMF", "vtu": "VTU"}
#: supported meshio 2-D cell type -> our cell type
CELL_NAMES = {"quad8": "QUAD8", "triangle6": "TRIA6"}
EDGE_TYPE, NODE_TYPE = "line3", "vertex"
#: separators meshio's ``join_strings`` tries, in its order
_JOIN_CHARS = "-_#+/"
_LINEAR_HINT = "mesh with quadratic elements: Gmsh -order 2, Salome 'quadratic mesh'"
_QUAD9_HINT = ("Gmsh writes order-2 quadrilaterals as quad9 unless "
               "Mesh.SecondOrderIncomplete=1")


def read_mesh(path, display_name=None):
    """Read the mesh file ``path`` (str or path-like) into a checked :class:`RawMesh`.

    ``display_name`` is the name used in messages and kept as ``source``
    (default: ``path`` as given).  Cells are re-oriented counter-clockwise by
    :meth:`RawMesh.check`.  Raises :class:`MeshError`.
    """
    source = display_name or os.fspath(path)
    fmt = _file_format(path, source)
    return from_meshio(_meshio_read(path, fmt, source), source, fmt)


def from_meshio(m, source="<meshio>", fmt=None):
    """Convert a ``meshio.Mesh`` into a checked :class:`RawMesh`.

    ``fmt`` is the meshio format the mesh was read from ("med", "gmsh", "xdmf",
    "vtu" or None): it selects where group names are looked for (integer data
    encoding sets are only decoded for "xdmf" and "vtu").
    """
    blocks = [(b.type, np.asarray(b.data, dtype=np.int64)) for b in m.cells]
    cell_type = _cell_type(blocks, source)
    points = _planar_points(np.asarray(m.points, dtype=float), source)
    typed = {t: _stack(blocks, t) for t in (cell_type, EDGE_TYPE, NODE_TYPE)}
    parts = {t: {} for t in typed}
    for name, k, idx in _block_sets(m, fmt, len(blocks)):
        kind = blocks[k][0]
        if kind in parts and len(idx):
            _add(parts[kind], name, typed[kind][1][k] + np.asarray(idx, dtype=np.int64))
    groups = {t: _unique_all(p) for t, p in parts.items()}
    node_parts = {name: [typed[NODE_TYPE][0][idx].ravel()]
                  for name, idx in groups[NODE_TYPE].items()}
    for name, idx in _point_sets(m, fmt, len(points), source):
        _add(node_parts, name, idx)
    mesh = RawMesh(
        points=points,
        cell_type=CELL_NAMES[cell_type],
        cells=np.ascontiguousarray(typed[cell_type][0]),
        cell_groups=groups[cell_type],
        edge_groups={name: typed[EDGE_TYPE][0][idx]
                     for name, idx in groups[EDGE_TYPE].items()},
        node_groups=_unique_all(node_parts),
        source=source,
        point_data=_scalar_point_data(m, len(points)))
    _check_group_nodes(mesh)
    return mesh.check()


# -- file --------------------------------------------------------------------
def _file_format(path, source):
    """meshio format name from the extension of ``path``; checks the file exists."""
    if not os.path.exists(path):
        raise MeshError(f"{source}: mesh file not found")
    if os.path.isdir(path):
        raise MeshError(f"{source}: is a directory, not a mesh file")
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in FORMATS:
        raise MeshError(f"{source}: unknown mesh format '{ext or '(no extension)'}' "
                        f"(supported: {', '.join(FORMATS)})")
    return FORMATS[ext]


def _meshio_read(path, fmt, source):
    """The ``meshio.Mesh`` in ``path``; every failure becomes a one-line MeshError."""
    # the format's own reader: meshio.read() turns reader errors into sys.exit(1)
    reader = importlib.import_module(f"meshio.{fmt}").read
    try:
        return reader(os.fspath(path))
    except Exception as exc:  # meshio, h5py and XML parsers raise many kinds
        text = " ".join(str(exc).split())
        detail = type(exc).__name__ + (f": {text}" if text else "")
        hint = ""
        if fmt == "xdmf" and isinstance(exc, KeyError):
            hint = ("; meshio cannot read XDMF 'Mixed' topologies with quadratic "
                    "cells: write one cell block, or use MED, Gmsh or VTU")
        raise MeshError(f"{source}: cannot read as {_FORMAT_NAMES[fmt]} "
                        f"({detail}){hint}") from exc


# -- geometry and cells ------------------------------------------------------------
def _planar_points(points, source):
    """``(n, 2)`` coordinates from meshio's ``(n, 2|3)``; z must be constant."""
    if points.ndim != 2 or points.shape[1] not in (2, 3) or len(points) == 0:
        raise MeshError(f"{source}: no 2-D node coordinates (shape {points.shape})")
    xy = points[:, :2]
    if points.shape[1] == 3:
        z = points[:, 2]
        size = max(float(np.ptp(xy, axis=0).max()), 1e-300)
        if np.ptp(z) > 1e-10 * size:
            raise MeshError(f"{source}: mesh is not planar (z from {z.min():g} to "
                            f"{z.max():g}); 2-D meshes in an x-y plane only")
    return np.ascontiguousarray(xy)


def _dimension(meshio_type):
    """Topological dimension of a meshio cell type (3 for anything else)."""
    if meshio_type == NODE_TYPE:
        return 0
    if meshio_type.startswith("line"):
        return 1
    if meshio_type.startswith(("triangle", "quad", "polygon")):
        return 2
    return 3


def _census(blocks, types):
    """``"quad8 x1600, line3 x160"`` for the blocks whose type is in ``types``."""
    count = {}
    for t, data in blocks:
        if t in types:
            count[t] = count.get(t, 0) + len(data)
    return ", ".join(f"{t} x{n}" for t, n in count.items()) or "nothing"


def _cell_type(blocks, source):
    """The one supported 2-D meshio type of ``blocks``, or MeshError.

    3-D cells are reported first, then unsupported 2-D cells (with hints),
    then 1-D cells other than line3.
    """
    types = {t for t, _ in blocks}
    dims = {t: _dimension(t) for t in types}
    solid = {t for t in types if dims[t] == 3}
    if solid:
        raise MeshError(f"{source}: unsupported cells {_census(blocks, solid)} "
                        f"(2-D meshes only)")
    plane = {t for t in types if dims[t] == 2}
    if not plane:
        raise MeshError(f"{source}: no 2-D cells (found: {_census(blocks, types)})")
    if len(plane) > 1 or not plane <= set(CELL_NAMES):
        _unsupported_plane(blocks, plane, source)
    lines = {t for t in types if dims[t] == 1 and t != EDGE_TYPE}
    if lines:
        raise MeshError(f"{source}: unsupported cells {_census(blocks, lines)} "
                        f"(edge groups must be {EDGE_TYPE} cells)")
    return plane.pop()


def _unsupported_plane(blocks, plane, source):
    """MeshError listing the 2-D cells found, what is supported and a hint."""
    hints = []
    if plane & {"triangle", "quad"}:
        hints.append(_LINEAR_HINT)
    if "quad9" in plane:
        hints.append(_QUAD9_HINT)
    if len(plane) > 1:
        hints.append("one cell type per mesh")
    supported = ", ".join(f"{k} ({v})" for k, v in CELL_NAMES.items())
    raise MeshError(f"{source}: unsupported 2-D cells {_census(blocks, plane)} "
                    f"(supported: exactly one of {supported})"
                    + "".join(f"; {h}" for h in hints))


def _stack(blocks, meshio_type):
    """Concatenated data of the blocks of ``meshio_type`` and per-block offsets.

    Returns ``(data (n, nn), offsets)`` with ``offsets[k]`` the row of block
    ``k``'s first cell in ``data`` (blocks of other types included, unused).
    """
    sizes = [len(d) if t == meshio_type else 0 for t, d in blocks]
    offsets = np.r_[0, np.cumsum(sizes)[:-1]].astype(np.int64)
    parts = [d for t, d in blocks if t == meshio_type]
    width = parts[0].shape[1] if parts else 1
    data = np.concatenate(parts) if parts else np.empty((0, width), np.int64)
    return data, offsets


# -- groups ------------------------------------------------------------------------
def _add(groups, name, idx):
    groups.setdefault(str(name), []).append(np.asarray(idx, dtype=np.int64).ravel())


def _unique_all(groups):
    return {name: np.unique(np.concatenate(parts)) for name, parts in groups.items()}


def _block_sets(m, fmt, n_blocks):
    """Yield ``(name, block, local cell indices)`` from every group source of ``m``."""
    yield from _tagged_sets(m.cell_data.get("cell_tags"), getattr(m, "cell_tags", {}))
    yield from _gmsh_sets(m)
    for name, per_block in (m.cell_sets or {}).items():
        if not name.startswith("gmsh:"):
            for k, idx in enumerate(per_block[:n_blocks]):
                if idx is not None:
                    yield name, k, idx
    if fmt in ("xdmf", "vtu"):
        for key, arrays in m.cell_data.items():
            names = _set_names(key, arrays)
            for k, a in enumerate(arrays if names else ()):
                for i, name in enumerate(names):
                    yield name, k, np.flatnonzero(np.asarray(a).ravel() == i)


def _tagged_sets(tags_per_block, families):
    """MED families: ``tags_per_block[k]`` family of each cell, ``families`` {tag: [names]}."""
    for k, tags in enumerate(tags_per_block or ()):
        tags = np.asarray(tags).ravel()
        for tag, names in (families or {}).items():
            idx = np.flatnonzero(tags == tag)
            for name in names if len(idx) else ():
                yield name, k, idx


def _gmsh_sets(m):
    """Gmsh physical groups: ``gmsh:physical`` tags named through ``field_data``."""
    physical = m.cell_data.get("gmsh:physical")
    if physical is None or len(physical) != len(m.cells):
        return
    names = {(int(v[0]), int(v[1])): name for name, v in m.field_data.items()
             if np.size(v) >= 2}
    for k, (block, tags) in enumerate(zip(m.cells, physical)):
        tags = np.asarray(tags).ravel()
        dim = _dimension(block.type)
        for tag in np.unique(tags[tags > 0]):
            yield names.get((int(tag), dim), str(tag)), k, np.flatnonzero(tags == tag)


def _set_names(key, arrays):
    """Set names of integer data written by meshio's ``*_sets_to_data``, or [].

    The data qualify when every value lies in ``[-1, len(names))`` for the
    names obtained by splitting ``key`` on the first of meshio's join
    characters that allows it.
    """
    arrays = [np.asarray(a) for a in arrays]
    if not arrays or any(a.dtype.kind not in "iu" or a.size != len(a) for a in arrays):
        return []
    values = np.concatenate([a.ravel() for a in arrays])
    if len(values) == 0 or values.min() < -1:
        return []
    for char in _JOIN_CHARS:
        names = key.split(char)
        if values.max() < len(names) and all(names):
            return names
    return []


def _point_sets(m, fmt, n_points, source):
    """Yield ``(name, node indices)`` from MED node families, point sets and data."""
    tags = m.point_data.get("point_tags")
    if tags is not None:
        tags = np.asarray(tags).ravel()
        if len(tags) != n_points:
            raise MeshError(f"{source}: node families given for {len(tags)} nodes "
                            f"but the mesh has {n_points}")
        for name, _, idx in _tagged_sets([tags], getattr(m, "point_tags", {})):
            yield name, idx
    for name, idx in (m.point_sets or {}).items():
        yield name, idx
    if fmt in ("xdmf", "vtu"):
        for key, a in m.point_data.items():
            for i, name in enumerate(_set_names(key, [a])):
                yield name, np.flatnonzero(np.asarray(a).ravel() == i)


def _scalar_point_data(m, n_points):
    """Real scalar nodal fields of the file (e.g. a level set), by name."""
    out = {}
    for key, a in (m.point_data or {}).items():
        a = np.asarray(a)
        if key in ("point_tags", "gmsh:dim_tags") or a.dtype.kind != "f":
            continue
        if a.ndim == 1 and len(a) == n_points or a.ndim == 2 and a.shape == (n_points, 1):
            out[key] = a.reshape(n_points).astype(float)
    return out


def _check_group_nodes(mesh):
    """MeshError if an edge or node group refers to a node the mesh does not have."""
    n = len(mesh.points)
    for kind, groups in (("edge", mesh.edge_groups), ("node", mesh.node_groups)):
        for name, idx in groups.items():
            bad = idx[(idx < 0) | (idx >= n)]
            if len(bad):
                raise MeshError(f"{mesh.source}: {kind} group {name} refers to node "
                                f"{int(bad[0])} but the mesh has {n} nodes")
