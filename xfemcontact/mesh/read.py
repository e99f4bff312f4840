"""Read a quadratic 2-D or 3-D mesh file into a checked :class:`RawMesh` (through meshio).

Supported files: MED (``.med``, ``.mmed``), Gmsh (``.msh``), XDMF (``.xdmf``,
``.xmf``) and VTU (``.vtu``).  The mesh must hold exactly one quadratic cell type of
its highest dimension: in 2-D meshio ``quad8`` (our QUAD8) or ``triangle6`` (our
TRIA6), in 3-D ``hexahedron20`` (HEXA20) or ``tetra10`` (TETRA10); several blocks
of it are concatenated in file order.  In a 3-D mesh the ``quad8`` / ``triangle6``
blocks (the faces of its cells) become face groups; ``line3`` blocks become edge
groups (rows ``(a, b, mid)``) and ``vertex`` blocks node groups; a block that
belongs to no group is dropped.  Node numbering is kept as in the file, unused
nodes included.  Coordinates are taken in the file's unit (m for our cases).

Node order: meshio keeps MED's (code_aster's, ours); the cells it reads from Gmsh,
XDMF and VTU files are in VTK's order, the mirror image of MED's for 3-D cells: they
are turned into ours (:attr:`~xfemcontact.fem.elements.Element.reverse`).

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

Reading is confined (:func:`check_input`, before meshio reads anything): the file
must be a regular file; the data an XDMF file refers to (HDF5 or binary DataItems)
and the HDF5 links and external storage of XDMF's and MED's HDF5 files must stay
inside the allowed folders (the case file's and the mesh file's), else the file is
refused without being read; XML declarations of entities and XIncludes are
refused.  Sizes are bounded: the file, the data it declares (HDF5 datasets) and
what decompresses from a VTU file may not exceed :func:`size_limit` (a fraction of
this machine's memory, ``-xfc_mesh_max_mb`` to change it).  Messages never print
data read from the files referred to.
"""
from __future__ import annotations

import contextlib
import importlib
import os
import re
from typing import TYPE_CHECKING, Any, Collection, Iterator, Mapping, NoReturn, Sequence

import numpy as np

from xfemcontact.errors import MeshError
from xfemcontact.mesh.raw import RawMesh

if TYPE_CHECKING:
    from types import ModuleType

    import meshio
    from numpy.typing import ArrayLike, NDArray

    FloatArray = NDArray[np.float64]
    IntArray = NDArray[np.int64]
    #: a file name as the callers give it
    PathName = str | os.PathLike[str]
    #: a meshio cell block: (meshio cell type, connectivity (k, nn))
    Block = tuple[str, IntArray]

#: fraction of the machine's memory the data of a mesh file may take by default
MEMORY_FRACTION = 1 / 16

#: file extension -> meshio format name
FORMATS = {".med": "med", ".mmed": "med", ".msh": "gmsh",
           ".xdmf": "xdmf", ".xmf": "xdmf", ".vtu": "vtu"}
_FORMAT_NAMES = {"med": "MED", "gmsh": "Gmsh", "xdmf": "XDMF", "vtu": "VTU"}
#: supported meshio 2-D cell type -> our cell type
CELL_NAMES = {"quad8": "QUAD8", "triangle6": "TRIA6"}
#: supported meshio 3-D cell type -> our cell type, and the meshio type of its faces
SOLID_NAMES = {"hexahedron20": "HEXA20", "tetra10": "TETRA10"}
FACE_TYPES = {"hexahedron20": "quad8", "tetra10": "triangle6"}
EDGE_TYPE, NODE_TYPE = "line3", "vertex"
#: separators meshio's ``join_strings`` tries, in its order
_JOIN_CHARS = "-_#+/"
_LINEAR_HINT = "mesh with quadratic elements: Gmsh -order 2, Salome 'quadratic mesh'"
_QUAD9_HINT = ("Gmsh writes order-2 quadrilaterals as quad9 unless "
               "Mesh.SecondOrderIncomplete=1")
_HEXA27_HINT = ("Gmsh writes order-2 hexahedra as hexahedron27 unless "
                "Mesh.SecondOrderIncomplete=1")


def read_mesh(path: PathName, display_name: str | None = None, roots: Sequence[PathName] | None = None,
              limit: int | None = None) -> RawMesh:
    """Read the mesh file ``path`` (str or path-like) into a checked :class:`RawMesh`.

    ``display_name`` is the name used in messages and kept as ``source``
    (default: ``path`` as given).  ``roots``: the folders the data it refers to
    may lie in (default: the mesh file's folder); ``limit``: the largest size
    in bytes of what it declares (default :func:`size_limit`).  Cells are
    re-oriented counter-clockwise by :meth:`RawMesh.check`.  Raises
    :class:`MeshError`.
    """
    source = display_name or os.fspath(path)
    fmt = _file_format(path, source)
    limit = size_limit() if limit is None else limit
    check_input(path, fmt, source, roots, limit)
    return from_meshio(_meshio_read(path, fmt, source, limit), source, fmt)


# -- confinement and sizes ------------------------------------------------------------
def memory_bytes() -> int:
    """This machine's memory (bytes), or the memory limit of our control group if lower."""
    try:
        total = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError):
        total = 8 << 30
    for name in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        with contextlib.suppress(OSError, ValueError):
            with open(name) as f:
                value = f.read().strip()
            if value.isdigit() and 0 < int(value) < total:
                total = int(value)
    return total


def size_limit() -> int:
    """Bytes a mesh file may declare: ``-xfc_mesh_max_mb``, else :data:`MEMORY_FRACTION`
    of :func:`memory_bytes`."""
    from xfemcontact import options

    given = options.get("mesh_max_mb")
    return int(given * 1e6) if given is not None else int(memory_bytes() * MEMORY_FRACTION)


def _mb(n: float) -> str:
    return f"{n / 1e6:.3g} MB"


def _too_big(source: str, what: str, size: int, limit: int) -> MeshError:
    return MeshError(f"{source}: {what} is {_mb(size)}, more than the {_mb(limit)} allowed "
                     f"(1/16 of this machine's memory; raise it with -xfc_mesh_max_mb)")


def check_input(path: PathName, fmt: str, source: str, roots: Sequence[PathName] | None = None,
                limit: int | None = None) -> None:
    """Refuse, before reading, a mesh file whose data lie outside ``roots`` or whose
    sizes exceed ``limit`` bytes (see the module documentation)."""
    limit = size_limit() if limit is None else limit
    real = [os.path.realpath(r) for r in (roots or [os.path.dirname(os.path.abspath(path))])]
    real = [r for r in real if r != os.path.dirname(r)] or real      # never the whole disk
    size = os.path.getsize(path)
    if size > limit:
        raise _too_big(source, "the file", size, limit)
    if fmt == "xdmf":
        _check_xdmf(path, source, real, limit)
    elif fmt == "med":
        _check_hdf5(path, source, real, limit, os.path.basename(path))
    elif fmt == "vtu":
        declared = _vtu_declared(path)
        if declared > limit:
            raise _too_big(source, "the data it declares (decompressed)", declared, limit)


def _inside(target: PathName, roots: Sequence[str]) -> bool:
    real = os.path.realpath(target)
    return any(os.path.commonpath([real, r]) == r for r in roots)


def _shown(text: object, limit: int = 80) -> str:
    """A name from a file, printable, its end kept when long (the file name matters)."""
    text = "".join(c if c.isprintable() else "?" for c in str(text))
    return text if len(text) <= limit else "..." + text[-(limit - 3):]


def _outside(source: str, what: str, ref: str) -> MeshError:
    return MeshError(f"{source}: {what} '{_shown(ref)}' lies outside the folders of the case "
                     f"and mesh files: refused (put the data next to the mesh file)")


def _check_xdmf(path: PathName, source: str, roots: Sequence[str], limit: int) -> None:
    from xml.etree import ElementTree as ET

    with open(path, "rb") as f:
        text = f.read()
    if re.search(rb"<!(DOCTYPE|ENTITY)", text):
        raise MeshError(f"{source}: XML document type or entity declarations are not accepted "
                        f"in mesh files")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise MeshError(f"{source}: cannot read as XDMF (not well-formed XML: "
                        f"{_shown(exc, 80)})") from None
    folder = os.path.dirname(os.path.abspath(path))
    total = 0
    for item in root.iter():
        tag = item.tag.rsplit("}", 1)[-1]
        if tag == "include":
            raise MeshError(f"{source}: XInclude elements are not accepted in mesh files")
        if tag != "DataItem" or "Reference" in item.attrib:
            continue
        fmt = item.get("Format", "XML")
        ref = (item.text or "").strip()
        if fmt == "Binary":                  # meshio opens it from the working folder
            if not _inside(ref, roots):
                raise _outside(source, "binary DataItem", ref)
            if not os.path.isfile(ref):
                raise MeshError(f"{source}: binary DataItem '{_shown(ref)}' not found")
            total += os.path.getsize(ref)
        elif fmt == "HDF":
            name = ref.split(":", 1)[0]
            target = os.path.join(folder, name)
            if not _inside(target, roots):
                raise _outside(source, "HDF5 DataItem", name)
            if not os.path.isfile(target):
                raise MeshError(f"{source}: HDF5 file '{_shown(name)}' of a DataItem not found")
        if total > limit:
            raise _too_big(source, "the data it refers to", total, limit)
    seen = set()
    for item in root.iter():
        if item.tag.rsplit("}", 1)[-1] == "DataItem" and item.get("Format") == "HDF":
            name = (item.text or "").strip().split(":", 1)[0]
            target = os.path.realpath(os.path.join(folder, name))
            if target not in seen:
                seen.add(target)
                total += _check_hdf5(target, source, roots, limit - total, name)


def _check_hdf5(path: PathName, source: str, roots: Sequence[str], limit: int, shown: str) -> int:
    """Walk an HDF5 file without reading data: external links, external and virtual
    storage inside ``roots``, declared dataset sizes within ``limit``; returns the bytes
    declared."""
    import h5py

    folder = os.path.dirname(os.path.abspath(path))
    try:
        f = h5py.File(path, "r")
    except OSError:
        return 0                              # not HDF5: the reader says what it is
    total = 0
    with f:
        stack, visited = [f], set()
        while stack:
            group = stack.pop()
            for key in list(group.keys()):
                link = group.get(key, getlink=True)
                if isinstance(link, h5py.ExternalLink):
                    candidates = [link.filename] if os.path.isabs(link.filename) else \
                        [os.path.join(folder, link.filename), link.filename]
                    if not all(_inside(c, roots) for c in candidates):
                        raise _outside(source, f"HDF5 external link in {shown} to",
                                       link.filename)
                    continue                  # its data is checked when read, if ever
                if isinstance(link, h5py.SoftLink):
                    continue
                obj = group[key]
                if isinstance(obj, h5py.Group):
                    if obj.id.__hash__() not in visited:
                        visited.add(obj.id.__hash__())
                        stack.append(obj)
                    continue
                if not isinstance(obj, h5py.Dataset):
                    continue
                for entry in obj.external or ():
                    name = os.fsdecode(entry[0])
                    if not _inside(name if os.path.isabs(name) else os.path.join(folder, name),
                                   roots) or not _inside(name, roots):
                        raise _outside(source, f"HDF5 external storage in {shown}:", name)
                if obj.is_virtual:
                    for vs in obj.virtual_sources():
                        name = vs.file_name
                        if name != "." and not _inside(
                                name if os.path.isabs(name) else os.path.join(folder, name), roots):
                            raise _outside(source, f"HDF5 virtual dataset in {shown} from", name)
                shape = obj.shape or ()
                total += int(np.prod(shape, dtype=np.float64)) * obj.dtype.itemsize
                if total > limit:
                    raise _too_big(source, f"the data {shown} declares", total, limit)
    return total


def _vtu_declared(path: PathName) -> int:
    """Bytes the compressed DataArrays of a VTU file decompress to, from their block
    headers (0 when uncompressed: then bounded by the file size; a header that cannot be
    parsed counts 0, and the decompression is bounded anyway, see :class:`_Budget`)."""
    import base64

    with open(path, "rb") as f:
        raw = f.read()
    head = raw[:4096]
    if b"compressor=" not in head:
        return 0
    found = re.search(rb'header_type="(\w+)"', head)
    itemsize = 8 if found and found.group(1) == b"UInt64" else 4
    order = ">" if b'byte_order="BigEndian"' in head else "<"
    dtype = np.dtype(f"{order}u{itemsize}")
    appended = re.search(rb"<AppendedData[^>]*>", raw)
    xml = raw[:appended.start()] if appended else raw
    blob = b""
    is_raw = False
    if appended:
        is_raw = b'encoding="raw"' in appended.group(0)
        end = raw.find(b"</AppendedData>", appended.end())
        blob = raw[appended.end():end if end > 0 else len(raw)].split(b"_", 1)[-1]

    def size(header_bytes: bytes) -> int:
        h = np.frombuffer(header_bytes[:3 * itemsize], dtype)
        if len(h) < 3:
            return 0
        n, block, last = (int(v) for v in h)
        return max(n - 1, 0) * block + (last or block) if n else 0

    def from_base64(text: bytes) -> int:            # 3 header items = 3 x itemsize bytes = 4 x itemsize chars
        return size(base64.b64decode(text[:4 * itemsize]))

    total = 0
    try:
        for m in re.finditer(rb"<DataArray\b([^>]*?)(/>|>(.*?)</DataArray>)", xml, re.S):
            attrs = m.group(1)
            found = re.search(rb'format="(\w+)"', attrs)
            fmt = found.group(1) if found else b"ascii"
            if fmt == b"binary":
                total += from_base64((m.group(3) or b"").strip())
            elif fmt == b"appended" and appended:
                found = re.search(rb'offset="\s*(\d+)', attrs)
                if found is None:             # no offset: what it declares is not known
                    return total
                offset = int(found.group(1))
                total += size(blob[offset:offset + 3 * itemsize]) if is_raw else \
                    from_base64(blob[offset:].lstrip())
    except (ValueError, AttributeError, TypeError):
        return total
    return total


class _Budget:
    """A decompressor (``zlib`` or ``lzma``) that refuses to produce more than ``left``
    bytes in all (meshio's VTU reader calls ``module.decompress``)."""

    def __init__(self, module: ModuleType, state: dict[str, int], source: str) -> None:
        self.module, self.state, self.source = module, state, source

    def __getattr__(self, name: str) -> Any:
        return getattr(self.module, name)

    def decompress(self, data: bytes) -> bytes:
        import lzma

        left = self.state["left"]
        d: Any = lzma.LZMADecompressor() if self.module is lzma else self.module.decompressobj()
        out = d.decompress(data, left + 1)
        if len(out) > left:
            raise _too_big(self.source, "its decompressed data", self.state["limit"] + 1,
                           self.state["limit"])
        self.state["left"] -= len(out)
        return out


@contextlib.contextmanager
def _bounded_decompression(fmt: str, source: str, limit: int) -> Iterator[None]:
    if fmt != "vtu":
        yield
        return
    import lzma
    import zlib

    vtu: Any = importlib.import_module("meshio.vtu._vtu")      # its zlib and lzma are replaced
    state = {"left": limit, "limit": limit}
    saved = vtu.zlib, vtu.lzma
    vtu.zlib, vtu.lzma = _Budget(zlib, state, source), _Budget(lzma, state, source)
    try:
        yield
    finally:
        vtu.zlib, vtu.lzma = saved


def from_meshio(m: meshio.Mesh, source: str = "<meshio>", fmt: str | None = None) -> RawMesh:
    """Convert a ``meshio.Mesh`` into a checked :class:`RawMesh`.

    ``fmt`` is the meshio format the mesh was read from ("med", "gmsh", "xdmf",
    "vtu" or None): it selects where group names are looked for (integer data
    encoding sets are only decoded for "xdmf" and "vtu").
    """
    blocks = [(b.type, np.asarray(b.data, dtype=np.int64)) for b in m.cells]
    cell_type = _cell_type(blocks, source)
    solid = cell_type in SOLID_NAMES
    points = _points(np.asarray(m.points, dtype=float), source, solid)
    if solid and fmt != "med":          # VTK's order (meshio's for these formats) -> MED's
        from xfemcontact.fem.elements import element

        reverse = element(SOLID_NAMES[cell_type]).reverse
        blocks = [(t, d[:, reverse] if t == cell_type else d) for t, d in blocks]
    face_type = FACE_TYPES.get(cell_type)
    kinds = (cell_type, EDGE_TYPE, NODE_TYPE) + ((face_type,) if face_type else ())
    typed = {t: _stack(blocks, t) for t in kinds}
    parts: dict[str, dict[str, list[IntArray]]] = {t: {} for t in typed}
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
        cell_type={**CELL_NAMES, **SOLID_NAMES}[cell_type],
        cells=np.ascontiguousarray(typed[cell_type][0]),
        cell_groups=groups[cell_type],
        edge_groups={name: typed[EDGE_TYPE][0][idx]
                     for name, idx in groups[EDGE_TYPE].items()},
        node_groups=_unique_all(node_parts),
        source=source,
        point_data=_scalar_point_data(m, len(points)),
        face_groups={name: typed[face_type][0][idx]
                     for name, idx in groups[face_type].items()} if face_type else {})
    _check_group_nodes(mesh)
    return mesh.check()


# -- file --------------------------------------------------------------------
def _file_format(path: PathName, source: str) -> str:
    """meshio format name from the extension of ``path``; checks the file exists."""
    if not os.path.exists(path):
        raise MeshError(f"{source}: mesh file not found")
    if os.path.isdir(path):
        raise MeshError(f"{source}: is a directory, not a mesh file")
    if not os.path.isfile(path):
        raise MeshError(f"{source}: not a regular file (a pipe or a device?): give a mesh file")
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in FORMATS:
        raise MeshError(f"{source}: unknown mesh format '{ext or '(no extension)'}' "
                        f"(supported: {', '.join(FORMATS)})")
    return FORMATS[ext]


def _meshio_read(path: PathName, fmt: str, source: str, limit: int | None = None) -> meshio.Mesh:
    """The ``meshio.Mesh`` in ``path``; every failure becomes a one-line MeshError."""
    # the format's own reader: meshio.read() turns reader errors into sys.exit(1)
    reader = importlib.import_module(f"meshio.{fmt}").read
    try:
        with _bounded_decompression(fmt, source, size_limit() if limit is None else limit):
            return reader(os.fspath(path))
    except MeshError:
        raise
    except MemoryError:
        raise MeshError(f"{source}: not enough memory to read it (lower -xfc_mesh_max_mb "
                        f"to refuse such files before reading)") from None
    except Exception as exc:  # meshio, h5py and XML parsers raise many kinds
        text = " ".join(str(exc).split())
        if _truncated(path, fmt, exc, text):
            raise MeshError(f"{source}: cannot read as {_FORMAT_NAMES[fmt]}: the file is "
                            f"truncated or corrupt (its data end before, or do not match, the "
                            f"sizes it declares)") from None
        text = text if len(text) <= 160 else text[:157] + "..."
        detail = type(exc).__name__ + (f": {text}" if text else "")
        hint = ""
        if fmt == "xdmf" and isinstance(exc, KeyError):
            hint = ("; meshio cannot read XDMF 'Mixed' topologies with quadratic "
                    "cells: write one cell block, or use MED, Gmsh or VTU")
        raise MeshError(f"{source}: cannot read as {_FORMAT_NAMES[fmt]} "
                        f"({detail}){hint}") from exc


def _truncated(path: PathName, fmt: str, exc: Exception, text: str) -> bool:
    """Whether a reader's failure means the file ends early or its sizes do not match."""
    import struct

    if isinstance(exc, (EOFError, struct.error)) or "cannot reshape" in text \
            or "buffer is smaller" in text or "end of file" in text.lower():
        return True
    if fmt == "gmsh":
        with contextlib.suppress(OSError):
            with open(path, "rb") as f:
                f.seek(max(os.path.getsize(path) - 256, 0))
                tail = f.read().rstrip()
            return not re.search(rb"\$End[A-Za-z]+$", tail)
    return False


# -- geometry and cells ------------------------------------------------------------
def _points(points: FloatArray, source: str, solid: bool) -> FloatArray:
    """Node coordinates: ``(n, 3)`` of a mesh of 3-D cells, else :func:`_planar_points`."""
    if not solid:
        return _planar_points(points, source)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) == 0:
        raise MeshError(f"{source}: 3-D cells need x, y, z node coordinates (shape {points.shape})")
    return np.ascontiguousarray(points)


def _planar_points(points: FloatArray, source: str) -> FloatArray:
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


def _dimension(meshio_type: str) -> int:
    """Topological dimension of a meshio cell type (3 for anything else)."""
    if meshio_type == NODE_TYPE:
        return 0
    if meshio_type.startswith("line"):
        return 1
    if meshio_type.startswith(("triangle", "quad", "polygon")):
        return 2
    return 3


def _census(blocks: Sequence[Block], types: Collection[str]) -> str:
    """``"quad8 x1600, line3 x160"`` for the blocks whose type is in ``types``."""
    count: dict[str, int] = {}
    for t, data in blocks:
        if t in types:
            count[t] = count.get(t, 0) + len(data)
    return ", ".join(f"{t} x{n}" for t, n in count.items()) or "nothing"


def _cell_type(blocks: Sequence[Block], source: str) -> str:
    """The one supported meshio type of the cells of ``blocks`` (3-D if any), or MeshError.

    Unsupported 3-D cells are reported first (with hints), then unsupported 2-D
    cells (with hints), then 1-D cells other than line3.
    """
    types = {t for t, _ in blocks}
    dims = {t: _dimension(t) for t in types}
    solid = {t for t in types if dims[t] == 3}
    if solid:
        return _solid_type(blocks, solid, {t for t in types if dims[t] == 2}, source)
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


def _solid_type(blocks: Sequence[Block], solid: set[str], plane: set[str], source: str) -> str:
    """The one supported 3-D meshio type of ``blocks`` (``solid``: its 3-D types, ``plane``
    its 2-D ones, which must be that cell's faces), or MeshError with hints."""
    if len(solid) > 1 or not solid <= set(SOLID_NAMES):
        hints = [_LINEAR_HINT] if solid & {"tetra", "hexahedron"} else []
        if "hexahedron27" in solid:
            hints.append(_HEXA27_HINT)
        _unsupported(blocks, solid, SOLID_NAMES, "3-D", hints, source)
    cell = next(iter(solid))
    faces = plane - {FACE_TYPES[cell]}
    if faces:
        raise MeshError(f"{source}: unsupported faces {_census(blocks, faces)} in a mesh of "
                        f"{cell} cells (face groups must be {FACE_TYPES[cell]} cells)")
    lines = {t for t, _ in blocks if _dimension(t) == 1 and t != EDGE_TYPE}
    if lines:
        raise MeshError(f"{source}: unsupported cells {_census(blocks, lines)} "
                        f"(edge groups must be {EDGE_TYPE} cells)")
    return cell


def _unsupported_plane(blocks: Sequence[Block], plane: set[str], source: str) -> NoReturn:
    """MeshError listing the 2-D cells found, what is supported and a hint."""
    hints = [_LINEAR_HINT] if plane & {"triangle", "quad"} else []
    if "quad9" in plane:
        hints.append(_QUAD9_HINT)
    _unsupported(blocks, plane, CELL_NAMES, "2-D", hints, source)


def _unsupported(blocks: Sequence[Block], found: set[str], names: Mapping[str, str], dim: str,
                 hints: list[str], source: str) -> NoReturn:
    """MeshError listing the ``dim`` cells ``found``, the supported ``names`` (meshio ->
    code_aster) and the ``hints``."""
    if len(found) > 1:
        hints = hints + ["one cell type per mesh"]
    supported = ", ".join(f"{k} ({v})" for k, v in names.items())
    raise MeshError(f"{source}: unsupported {dim} cells {_census(blocks, found)} "
                    f"(supported: exactly one of {supported})"
                    + "".join(f"; {h}" for h in hints))


def _stack(blocks: Sequence[Block], meshio_type: str) -> tuple[IntArray, IntArray]:
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
def _add(groups: dict[str, list[IntArray]], name: object, idx: ArrayLike) -> None:
    groups.setdefault(str(name), []).append(np.asarray(idx, dtype=np.int64).ravel())


def _unique_all(groups: dict[str, list[IntArray]]) -> dict[str, IntArray]:
    return {name: np.unique(np.concatenate(parts)) for name, parts in groups.items()}


def _block_sets(m: meshio.Mesh, fmt: str | None, n_blocks: int) -> Iterator[tuple[str, int, IntArray]]:
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


def _tagged_sets(tags_per_block: Sequence[ArrayLike] | None,
                 families: dict[int, list[str]] | None) -> Iterator[tuple[str, int, IntArray]]:
    """MED families: ``tags_per_block[k]`` family of each cell, ``families`` {tag: [names]}."""
    for k, tags in enumerate(tags_per_block or ()):
        tags = np.asarray(tags).ravel()
        for tag, names in (families or {}).items():
            idx = np.flatnonzero(tags == tag)
            for name in names if len(idx) else ():
                yield name, k, idx


def _gmsh_sets(m: meshio.Mesh) -> Iterator[tuple[str, int, IntArray]]:
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


def _set_names(key: str, arrays: Sequence[ArrayLike]) -> list[str]:
    """Set names of integer data written by meshio's ``*_sets_to_data``, or [].

    The data qualify when every value lies in ``[-1, len(names))`` for the
    names obtained by splitting ``key`` on the first of meshio's join
    characters that allows it.
    """
    arrs = [np.asarray(a) for a in arrays]
    if not arrs or any(a.dtype.kind not in "iu" or a.size != len(a) for a in arrs):
        return []
    values = np.concatenate([a.ravel() for a in arrs])
    if len(values) == 0 or values.min() < -1:
        return []
    for char in _JOIN_CHARS:
        names = key.split(char)
        if values.max() < len(names) and all(names):
            return names
    return []


def _point_sets(m: meshio.Mesh, fmt: str | None, n_points: int,
                source: str) -> Iterator[tuple[str, IntArray]]:
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


def _scalar_point_data(m: meshio.Mesh, n_points: int) -> dict[str, FloatArray]:
    """Real scalar nodal fields of the file (e.g. a level set), by name."""
    out: dict[str, FloatArray] = {}
    for key, a in (m.point_data or {}).items():
        a = np.asarray(a)
        if key in ("point_tags", "gmsh:dim_tags") or a.dtype.kind != "f":
            continue
        if a.ndim == 1 and len(a) == n_points or a.ndim == 2 and a.shape == (n_points, 1):
            out[key] = a.reshape(n_points).astype(float)
    return out


def _check_group_nodes(mesh: RawMesh) -> None:
    """MeshError if a face, edge or node group refers to a node the mesh does not have."""
    n = len(mesh.points)
    for kind, groups in (("face", mesh.face_groups), ("edge", mesh.edge_groups), ("node", mesh.node_groups)):
        for name, idx in groups.items():
            bad = idx[(idx < 0) | (idx >= n)]
            if len(bad):
                raise MeshError(f"{mesh.source}: {kind} group {name} refers to node "
                                f"{int(bad[0])} but the mesh has {n} nodes")
