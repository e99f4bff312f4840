"""results.json and the field files ParaView opens."""
import numpy as np

from xfemcontact import __version__, timing
from xfemcontact.post import fields, gather

MESHIO_CELL = {"QUAD8": "quad8", "TRIA6": "triangle6"}


def summary(model, converged, reason, outcomes):
    """The content of results.json (a dict; rank 0's values)."""
    case, snes = model.case, model.snes
    mpi = model.comm.tompi4py()
    return {
        "xfemcontact": __version__,
        "case": case.name,
        "title": case.title,
        "converged": bool(converged),
        "reason": int(reason),
        "processes": model.comm.size,
        "mesh": {"cell_type": model.mesh.cell_type,
                 "cells": mpi.allreduce(len(model.mesh.cells)),
                 "nodes": mpi.allreduce(int(model.mesh.node_owned.sum()))},
        "dofs": dict(model.layout.counts(), total=model.layout.global_size),
        "iterations": iterations(model),
        "residual_history": list(model.newton_test.history if snes else []),
        "warnings": list(model.loops.warnings) if model.loops else [],
        "linear_solver": model.solver_info(),
        "geometry": geometry_summary(model),
        "multipliers": model.space.summary() if model.space is not None else None,
        "timings": {k: round(v, 4) for k, v in timing.TIMINGS.items()},
        "tests": [o.as_dict() for o in outcomes],
        "interface": interface_table(model),
    }


def iterations(model):
    """Iteration counts of every loop."""
    loops = model.loops
    if loops is None:
        return {"newton": model.snes.getIterationNumber() if model.snes else 0}
    return {"newton": int(sum(loops.newton)), "newton_per_solve": list(loops.newton),
            "contact": list(loops.contact), "friction": int(loops.friction),
            "status_changes": list(loops.status_changes),
            "threshold_changes": [float(c) for c in loops.threshold_changes]}


def geometry_summary(model):
    geo = model.geo
    if geo is None:
        return None
    mpi = model.comm.tompi4py()
    r = geo.readjustment
    return {"cut_cells": mpi.allreduce(len(geo.cut_cells)),
            "edge_segments": mpi.allreduce(len(geo.edge_segments)),
            "enriched_nodes": mpi.allreduce(int((geo.enriched & model.mesh.node_owned).sum())),
            "dropped_heaviside_nodes": mpi.allreduce(geo.dropped),
            "readjusted": {"roundoff": mpi.allreduce(r.roundoff), "fitted_vertices": mpi.allreduce(r.fitted_vertices),
                           "lifted_edges": mpi.allreduce(r.lifted_edges)}}


def interface_table(model):
    """Interface point values gathered on rank 0, ordered by (input cell, end)."""
    v = model.interface_values()
    if v is None:
        return None
    parts = model.comm.tompi4py().gather(v, root=0)
    if parts is None:
        return None
    allv = {k: np.concatenate([p[k] for p in parts]) for k in v}
    order = np.lexsort((allv["end"], allv["cell"]))
    keys = ("x", "y", "LAGS_C", "LAGS_F1", "gap", "slip", "contact", "sliding", "cell", "end")
    return {k: allv[k][order].tolist() for k in keys}


def write_fields(folder, model, u, values):
    """Displacements at nodes and mean stresses per cell, as XDMF (and VTU if asked)."""
    mesh = model.mesh
    sig, eps = fields.cell_means(mesh, values)
    nodes = gather.gather_nodes(mesh, u=u)
    cells = gather.gather_cells(mesh, sig=sig, eps=eps)
    if nodes is None:
        return
    import meshio

    ids, x, nd = nodes
    _, conn, cd = cells
    index = np.full(int(ids.max()) + 1, -1, dtype=np.int64)
    index[ids] = np.arange(len(ids))
    cell_data = {
        "SIXX": [cd["sig"][:, 0]], "SIYY": [cd["sig"][:, 1]], "SIXY": [cd["sig"][:, 2]],
        "EPXX": [cd["eps"][:, 0]], "EPYY": [cd["eps"][:, 1]], "EPXY": [0.5 * cd["eps"][:, 2]],
    }
    m = meshio.Mesh(np.c_[x, np.zeros(len(x))], [(MESHIO_CELL[mesh.cell_type], index[conn])],
                    point_data={"DX": nd["u"][:, 0], "DY": nd["u"][:, 1],
                                "displacement": np.c_[nd["u"], np.zeros(len(x))]},
                    cell_data=cell_data)
    formats = model.case.output.formats
    if "xdmf" in formats:
        _write_xdmf(folder, "fields.xdmf", m)
    if "vtu" in formats:
        meshio.write(folder.file("fields.vtu"), m, file_format="vtu")


def _write_xdmf(folder, name, m):
    """XDMF + HDF5 with a relative data path (the folder is renamed afterwards)."""
    import os

    import meshio

    cwd = os.getcwd()
    os.chdir(folder.file("."))
    try:
        meshio.write(name, m, file_format="xdmf")
    finally:
        os.chdir(cwd)
