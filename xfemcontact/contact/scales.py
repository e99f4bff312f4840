"""The natural scales of a contact problem, and the augmentation coefficients they give.

``h``: the mean edge length of the cut cells (m, over every process).  When the
case gives no COEF_CONT it is E / h (Pa/m: the stiffness of a layer of cells
per unit area); no COEF_FROT: E / (h mu |p|) (1/m), p the pressure scale of the
friction threshold, so that COEF_FROT mu |p| = E / h too.  Both are only
algorithmic (see :mod:`xfemcontact.contact.nodal`): these values keep the
scaled rows of the tangent of the order of the others.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from mpi4py import MPI

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from xfemcontact.mesh.plex import LocalMesh
    from xfemcontact.xfem.geometry import Geometry


@dataclass(frozen=True)
class Coefficients:
    """The augmentation coefficients and the length scale they come from."""
    coef_cont: float            # Pa/m
    coef_frot: float | None     # 1/m; None: E / (h mu |p|), p known once friction is bounded
    h: float                    # m


def mean_cut_edge(mesh: LocalMesh, geo: Geometry | None) -> float:
    """Mean edge length of the cut cells of every process (m; cells are not shared
    between processes); the mean over this process's cells when none is cut."""
    el = mesh.element
    cells = np.asarray(geo.cut_cells) if geo is not None else np.zeros(0, int)
    if not len(cells):
        cells = np.arange(len(mesh.cells))
    xv = mesh.x[mesh.cell_nodes[cells, :el.nv]]
    lengths = np.linalg.norm(xv - np.roll(xv, 1, axis=1), axis=2)
    mpi = mesh.comm.tompi4py()
    total = mpi.allreduce(float(lengths.sum()), op=MPI.SUM)
    count = mpi.allreduce(lengths.size, op=MPI.SUM)
    return total / max(count, 1)


def coefficients(case: Any, mesh: LocalMesh, geo: Geometry | None,
                 weights: NDArray[np.float64] | None = None) -> Coefficients:
    """COEF_CONT and COEF_FROT of ``case``, or their natural values (see the module).

    ``case``: the :class:`~xfemcontact.case.load.Case` (not imported: the case package
    imports the contact laws, which use this module); ``weights`` is not used."""
    c = case.contact
    h = mean_cut_edge(mesh, geo)
    E = case.material.E
    return Coefficients(c.coef_cont if c.coef_cont is not None else E / h, c.coef_frot, h)
