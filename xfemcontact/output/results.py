"""results.json and the field files ParaView opens."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Iterable

import numpy as np

from xfemcontact import __version__, resources, timing

if TYPE_CHECKING:
    from xfemcontact._petsc import PETSc
    from xfemcontact.model import Model
    from xfemcontact.output.folder import OutputFolder
    from xfemcontact.post.postmesh import PostMesh
    from xfemcontact.post.testtable import Outcome

MESHIO_CELL = {"QUAD8": "quad8", "TRIA6": "triangle6"}


def summary(model: Model, converged: bool, reason: int, outcomes: Iterable[Outcome]) -> dict[str, Any]:
    """The content of results.json (a dict; rank 0's values)."""
    case, solver = model.case, model.solver
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
        "partition": model.mesh.partition,
        "iterations": solver.iterations() if solver else {"newton": 0},
        "residual_history": list(solver.newton_test.history if solver else []),
        "warnings": model.run_warnings(),
        "linear_solver": model.solver_info(),
        "geometry": geometry_summary(model),
        "multipliers": model.problem.summary() if model.problem is not None else None,
        "conditions": model.problem.conditions(model.x) if model.problem is not None else None,
        "timings": {k: round(v, 4) for k, v in timing.TIMINGS.items()},
        "solver_events": timing.solver_events(model.comm),
        "timing_steps": {k: round(v, 4) for k, v in timing.STEPS.items()},
        "memory": {"peak_mb_per_process": timing.peak_memory_mb(model.comm),
                   "phases": timing.phase_memory(model.comm)},
        "resources": resources.summary(),
        "tests": [o.as_dict() for o in outcomes],
        "interface": interface_table(model),
    }


def geometry_summary(model: Model) -> dict[str, Any] | None:
    """Cut cells, segments (3-D: facets and the interface area, m^2) and enriched nodes over
    every process (None without interface)."""
    geo = model.geo
    if geo is None:
        return None
    mpi = model.comm.tompi4py()
    r = geo.readjustment
    facets = {}
    if model.mesh.dim == 3:             # the interface is made of facets, not segments
        live = sum(int(f.live.sum()) for f in (geo.facets, geo.face_facets) if f is not None)
        area = sum(float(p.w.sum()) for p in geo.interface_points(model.mesh))
        facets = {"interface_facets": mpi.allreduce(live), "interface_area": mpi.allreduce(area),
                  "off_surface_midnodes": mpi.allreduce(geo.off_surface), "folded_cells": mpi.allreduce(geo.folded)}
    return {**facets, "cut_cells": mpi.allreduce(len(geo.cut_cells)),
            "cut_cells_per_process": mpi.allgather(len(geo.cut_cells)),
            "edge_segments": mpi.allreduce(len(geo.edge_segments)),
            "enriched_nodes": mpi.allreduce(int((geo.enriched & model.mesh.node_owned).sum())),
            "dropped_heaviside_nodes": mpi.allreduce(geo.dropped),
            "readjusted": {"roundoff": mpi.allreduce(r.roundoff), "fitted_vertices": mpi.allreduce(r.fitted_vertices),
                           "lifted_edges": mpi.allreduce(r.lifted_edges),
                           "pushed_off_edges": mpi.allreduce(r.pushed_off),
                           "double_crossed_edges": mpi.allreduce(r.double_crossings)}}


def interface_table(model: Model) -> dict[str, list[Any]] | None:
    """Interface point values gathered on rank 0, ordered by (input cell, end)."""
    v = model.interface_values()
    if v is None:
        return None
    parts = model.comm.tompi4py().gather(v, root=0)
    if parts is None:
        return None
    allv = {k: np.concatenate([p[k] for p in parts]) for k in v}
    order = np.lexsort((allv["end"], allv["cell"]))
    keys: tuple[str, ...] = ("x", "y", "LAGS_C", "LAGS_F1", "gap", "slip", "contact", "sliding", "cell", "end")
    if model.mesh.dim == 3:             # the facets' Gauss points (interface_csv.build3d)
        keys = ("x", "y", "z", "w", "LAGS_C", "LAGS_F1", "LAGS_F2", "T", "gap", "slip1", "slip2", "slip",
                "contact", "sliding", "cell", "end")
    return {k: allv[k][order].tolist() for k in keys}


def build_post(model: Model) -> PostMesh | None:
    """The post-processing mesh (:func:`xfemcontact.post.postmesh.build`); collective,
    None where there is none."""
    from xfemcontact.post import postmesh

    with timing.step("output:postmesh"):
        return postmesh.build(model)


def write_field_files(folder: OutputFolder, model: Model, post: PostMesh | None) -> list[str]:
    """The fields of the post-processing mesh ``post`` (see :mod:`xfemcontact.post.postmesh`)
    as fields.xdmf + fields.h5 (and fields.vtu, fields.med if asked); in 3-D its interface
    surface (:mod:`xfemcontact.post.surface`) as interface.xdmf + interface.h5 (and
    interface.vtu with vtu).  Collective; returns the file names written on rank 0."""
    if post is None:
        return []
    formats = model.case.output.formats
    written: list[str] = []
    if "xdmf" in formats:
        from xfemcontact.output import xdmf

        with timing.step("output:xdmf"):
            for name, mesh in field_meshes(post):
                xdmf.write(folder.file(f"{name}.xdmf"), mesh)
                written += [f"{name}.xdmf", f"{name}.h5"]
    return written + write_meshio_formats(folder, post, formats)


def field_meshes(post: PostMesh) -> list[tuple[str, PostMesh]]:
    """The meshes of the field files, by file stem: ``fields`` (the post-processing mesh)
    and, in 3-D with an interface, ``interface`` (its interface surface)."""
    return [("fields", post)] + ([("interface", post.interface)] if post.interface is not None else [])


def write_meshio_formats(folder: OutputFolder, post: PostMesh, formats: Iterable[str]) -> list[str]:
    """The field files meshio writes, as ``formats`` asks: ``vtu`` -> fields.vtu (and
    interface.vtu, :func:`field_meshes`), ``med`` -> fields.med.  Rank 0 (``post``);
    returns the names written."""
    formats = set(formats)
    if not formats & {"vtu", "med"}:
        return []
    import meshio

    written: list[str] = []
    if "vtu" in formats:
        for name, mesh in field_meshes(post):
            meshio.write(folder.file(f"{name}.vtu"), mesh.to_meshio(), file_format="vtu")
            written.append(f"{name}.vtu")
    if "med" in formats:
        meshio.write(folder.file("fields.med"), post.to_meshio(med=True), file_format="med")
        written.append("fields.med")
    return written


def write_outputs(folder: OutputFolder, model: Model, converged: bool, reason: int,
                  outcomes: Iterable[Outcome], warnings: Iterable[str] = ()) -> None:
    """Every result file but results.json: fields, interface.csv, plots, report.md.
    Collective; only rank 0 writes.  ``warnings``: more lines for report.md (the
    input checks' warnings).

    The plots go to the folder's plot helper process when there is a spare core,
    in two batches, and are drawn here otherwise or when it fails
    (:mod:`xfemcontact.output.plotter`): the files are the same.
    """
    from xfemcontact.output import interface_csv, report
    from xfemcontact.post import plots

    rank0 = model.comm.rank == 0
    case = model.case
    idle = local_peers(model.comm) if case.output.plots else 0
    want_plots = rank0 and case.output.plots
    helper = folder.start_plot_helper(idle) if want_plots else None      # imports matplotlib meanwhile
    with timing.step("output:interface"):
        table = interface_csv.build(model)
    summary_now = summary(model, converged, reason, outcomes)
    title = case.title if converged else f"{case.title} -- NOT CONVERGED (last iterate)"
    title = title.replace("$", r"\$")         # text, not mathtext
    here = []                                  # plot jobs drawn by this process
    if helper is not None:                     # plots wanted (rank 0 has the helper)
        criterion = case.newton.resi_glob_rela * model.load_norm if model.solver else None
        resi_frot = case.contact.resi_frot if model.solver and model.solver.record else None
        jobs = plots.line_jobs(title, table, summary_now["residual_history"], summary_now["iterations"],
                               criterion, resi_frot)
        if not helper.send(jobs, folder.file(".")):
            here += jobs
    post = build_post(model)
    if helper is not None:     # the plots of the mesh first: the helper draws them while the files are written
        with timing.step("output:plots"):
            jobs = plots.mesh_jobs(title, post, table, case.material.E,
                                   friction=bool(model.problem is not None and model.problem.friction),
                                   multipliers=bool(model.law is not None and model.law.multipliers),
                                   references=case.reference,
                                   profile=(case.output.profile_point, case.output.profile_normal))
            if not helper.send(jobs, folder.file(".")):
                here += jobs
    files = write_field_files(folder, model, post)
    if not rank0:
        wait_quietly(model.comm)
        return
    warnings = list(warnings)
    if table is not None:
        with timing.step("output:interface"):
            files += interface_csv.write(folder, table)
        warnings += table.warnings
    if helper is not None:
        with timing.step("output:plots"):
            drawn = plots.run(folder, here)
        with timing.step("output:plots_wait"):
            drawn += helper.finish()
            missing = [job for job in helper.jobs if job[0] not in drawn]
        for name, cpu in helper.times.items():      # the helper's CPU seconds, for the bench
            timing.STEPS[f"plot_helper_cpu:{name}"] = cpu
        if missing:
            drawn += plots.run(folder, missing)
        files += [name for name in plots.ORDER if name in drawn]
    with timing.step("output:report"):
        report.write(folder, summary_now, files, case_source=case.source, warnings=warnings)
    wait_quietly(model.comm)


def local_peers(comm: PETSc.Comm) -> int:
    """The other processes of the run on rank 0's machine (collective; 0 on one process):
    they wait in :func:`wait_quietly` while rank 0 writes, so their cores can draw."""
    if comm.size == 1:
        return 0
    from mpi4py import MPI

    mpi = comm.tompi4py()
    node = mpi.Split_type(MPI.COMM_TYPE_SHARED)
    peers = node.Get_size() - 1
    node.Free()
    return int(mpi.bcast(peers, root=0))


def wait_quietly(comm: PETSc.Comm, pause: float = 0.002) -> None:
    """A barrier that sleeps instead of spinning (collective): Open MPI's busy polling
    in a collective would take the core of a process that is done away from rank 0's
    plot helpers."""
    if comm.size == 1:
        return
    import time

    request = comm.tompi4py().Ibarrier()
    while not request.Test():
        time.sleep(pause)
