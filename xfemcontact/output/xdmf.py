"""fields.xdmf + fields.h5: the post-processing mesh for ParaView (XDMF3, HDF5 data).

Written directly with h5py, one dataset per array in a single pass, in the
layout meshio 5's XDMF writer uses (``data0`` the points, z = 0 in 2-D, ``data1``
the cells, then the point fields and the cell fields, in that order; a Mixed
topology when there are quadrangles and triangles): the files are the ones
meshio wrote before, byte for byte in the XML and value for value in the HDF5,
without importing meshio (0.2 s) or building its mesh object first.
"""
from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import h5py
    from numpy.typing import NDArray

    from xfemcontact.post.postmesh import PostMesh

#: XDMF topology names and Mixed-topology type codes of our cell types (meshio's names;
#: XDMF's node order of the 3-D cells is VTK's, meshio's)
XDMF_TYPE = {"quad8": "Quadrilateral_8", "triangle6": "Triangle_6",
             "hexahedron20": "Hexahedron_20", "tetra10": "Tetrahedron_10"}
XDMF_CODE = {"quad8": 0x25, "triangle6": 0x24, "hexahedron20": 0x30, "tetra10": 0x26}
_DTYPE = {"int32": ("Int", "4"), "int64": ("Int", "8"), "float32": ("Float", "4"), "float64": ("Float", "8")}


def _attribute_type(data: NDArray[Any]) -> str:
    if data.ndim == 1 or (data.ndim == 2 and data.shape[1] == 1):
        return "Scalar"
    if data.ndim == 2 and data.shape[1] in (2, 3):
        return "Vector"
    raise ValueError(f"unsupported field shape {data.shape}")


class _Writer:
    def __init__(self, h5: h5py.File, h5_name: str) -> None:
        self.h5, self.h5_name, self.count = h5, h5_name, 0

    def item(self, parent: ET.Element, data: NDArray[Any], dims: str | None = None) -> None:
        """A DataItem under ``parent`` pointing to a new dataset holding ``data``."""
        dt, prec = _DTYPE[data.dtype.name]
        node = ET.SubElement(parent, "DataItem", DataType=dt,
                             Dimensions=dims or " ".join(str(s) for s in data.shape),
                             Format="HDF", Precision=prec)
        name = f"data{self.count}"
        self.count += 1
        self.h5.create_dataset(name, data=data)
        node.text = f"{self.h5_name}:/{name}"


def write(path: str | os.PathLike[str], post: PostMesh) -> None:
    """Write ``path`` (``.xdmf``) and the HDF5 file next to it (same stem, ``.h5``) for
    the :class:`~xfemcontact.post.postmesh.PostMesh` ``post``.  The XDMF file names
    the HDF5 file without a folder, so the pair can be moved together."""
    import h5py

    path = os.fspath(path)
    h5_path = os.path.splitext(path)[0] + ".h5"
    root = ET.Element("Xdmf", Version="3.0")
    grid = ET.SubElement(ET.SubElement(root, "Domain"), "Grid", Name="Grid")
    n = len(post.points)
    with h5py.File(h5_path, "w") as h5:
        w = _Writer(h5, os.path.basename(h5_path))
        pts = np.zeros((n, 3))
        pts[:, :post.points.shape[1]] = post.points
        w.item(ET.SubElement(grid, "Geometry", GeometryType="XYZ"), pts, f"{n} 3")
        del pts
        blocks = [(t, np.asarray(c)) for t, c in post.blocks]
        if len(blocks) == 1:
            t, c = blocks[0]
            topo = ET.SubElement(grid, "Topology", TopologyType=XDMF_TYPE[t], NumberOfElements=str(len(c)),
                                 NodesPerElement=str(c.shape[1]))
            w.item(topo, c, "{} {}".format(*c.shape))
        elif blocks:
            ncells = sum(len(c) for _, c in blocks)
            topo = ET.SubElement(grid, "Topology", TopologyType="Mixed", NumberOfElements=str(ncells))
            mixed = np.concatenate([np.hstack([np.full((len(c), 1), XDMF_CODE[t], c.dtype), c]).ravel()
                                    for t, c in blocks])
            w.item(topo, mixed, str(len(mixed)))
        for name, data in post.point_fields():
            att = ET.SubElement(grid, "Attribute", Name=name, AttributeType=_attribute_type(data), Center="Node")
            w.item(att, data)
        for name, parts in post.cell_data.items():
            data = np.concatenate(parts)
            att = ET.SubElement(grid, "Attribute", Name=name, AttributeType=_attribute_type(data), Center="Cell")
            w.item(att, data)
    ET.ElementTree(root).write(path)
