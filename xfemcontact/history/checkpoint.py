"""Checkpoints of the completed load steps, and the restart from them.

They live in a folder beside the output folder, ``OUT.checkpoints`` (visible,
never touched by the output folder's clean-up of temporary folders), holding:

* ``README.txt``: what the folder is and how to resume;
* ``manifest.json``: the case (SHA-256 of the case file and of the mesh file),
  the number of processes and how the dofs are split among them, the number of
  completed steps, the instant reached and the steps still to do (cut steps
  included); written last, atomically, after every completed step: it is what
  a restart trusts;
* ``step-NNNNNN.json``: the record of step NNNNNN (instant, iterations, the
  interface table, the tests at that instant);
* ``step-NNNNNN.pP-of-N.npz``: the solution (this process's part of the global
  vector) and the interface problem's state after step NNNNNN, per process.

A run writes step ``n``'s files, then the manifest: a run killed at any moment
(SIGKILL included) leaves the manifest of its last completed step.
``xfemcontact run CASE -o OUT --restart`` reads it, checks that the case file,
the mesh file, the number of processes and the dof layout are those of the
checkpoints (else exit code 2, one line), and resumes after the last completed
step.  The folder is removed once a run has written its results; it is kept when
the run stops without convergence (exit code 3) or is interrupted.  A run
without ``--restart`` refuses to start over an existing checkpoint folder
unless ``--overwrite`` is given.  The folder is locked (``flock``) while a run
uses it.
"""
from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import shutil
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from xfemcontact.errors import CaseError

if TYPE_CHECKING:
    from mpi4py import MPI

    from xfemcontact.case.load import Case
    from xfemcontact.model import Model

SUFFIX = ".checkpoints"
FORMAT = 1
README = """Checkpoints of xfemcontact: the completed load steps of the case
    {case}
computed into the result folder
    {out}
Resume a run that was stopped (killed, interrupted, out of time) after its last
completed step with

    xfemcontact run {case} -o {out} --restart

(under mpirun: with the same number of processes).  manifest.json says how far it
got; step-*.json hold the steps' records, step-*.npz the solutions and contact
states.  The folder is removed when a run completes.
"""


class CheckpointError(CaseError):
    """Nothing to restart from, or checkpoints that do not match (exit code 2)."""

    collective = True


def folder_of(outdir: str | os.PathLike[str]) -> Path:
    """The checkpoint folder of the output folder ``outdir``: ``OUT.checkpoints`` beside it."""
    p = Path(outdir)
    name = p.name if p.name not in ("", ".", "..") else p.resolve().name
    return p.parent / (name + SUFFIX)


def case_digest(case: Case) -> dict[str, str]:
    """SHA-256 of the case file and of the mesh file (if any)."""
    def digest(path: str | os.PathLike[str]) -> str:
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
        return h.hexdigest()

    out = {"case": digest(case.path)}
    if case.mesh.file is not None:
        out["mesh"] = digest(case.mesh.file)
    return out


def _lock(path: Path) -> int | None:
    """An exclusive lock on the folder ``path``: its descriptor, None when it cannot be
    opened, -1 when another process holds the lock."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return -1
    return fd


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".part")
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class Checkpoints:
    """The checkpoint folder of one run (see the module documentation).

    Construct it on every process after the output folder was checked; rank 0
    decides and every process raises the same :class:`CheckpointError`.
    ``restart``: resume (the manifest must exist and match); ``overwrite``: an
    existing folder may be replaced by a new run.
    """

    def __init__(self, outdir: str | os.PathLike[str], case: Case, comm: MPI.Comm, restart: bool = False,
                 overwrite: bool = False) -> None:
        self.comm = comm                      # mpi4py
        self.path = folder_of(outdir)
        self.case = case
        self.restart = restart
        self.manifest: dict[str, Any] | None = None
        self._fd: int | None = None
        self._started = False
        self._layout: list[list[Any]] = []
        problem: str | None = None
        manifest: dict[str, Any] | None = None
        if comm.rank == 0:
            try:
                manifest = self._check(outdir, overwrite)
            except CheckpointError as exc:
                problem = str(exc)
        if comm.size > 1:
            problem, manifest = comm.bcast((problem, manifest), root=0)
        if problem:
            raise CheckpointError(problem)
        self.manifest = manifest

    # -- the checks before the mesh is read ---------------------------------------
    def _check(self, outdir: str | os.PathLike[str], overwrite: bool) -> dict[str, Any] | None:
        path = self.path
        shown = str(path)
        exists = path.is_dir()
        if self.restart:
            if not exists or not (path / "manifest.json").is_file():
                raise CheckpointError(f"{outdir}: nothing to restart from (no checkpoint in "
                                      f"{shown}; run without --restart)")
            manifest = self._read_manifest()
            if manifest.get("format") != FORMAT:
                raise CheckpointError(f"{shown}: checkpoints of another version of xfemcontact: "
                                      f"cannot restart (run without --restart, with --overwrite)")
            if manifest.get("digest") != case_digest(self.case):
                which = "mesh file" if manifest.get("digest", {}).get("case") == \
                    case_digest(self.case)["case"] else "case file"
                raise CheckpointError(f"{shown}: the {which} changed since the checkpoints were "
                                      f"written: cannot restart (run without --restart, with "
                                      f"--overwrite, to start over)")
            if manifest.get("processes") != self.comm.size:
                raise CheckpointError(f"{shown}: written by {manifest.get('processes')} process(es), "
                                      f"this run has {self.comm.size}: restart with the same "
                                      f"number of processes")
            if not manifest.get("completed"):
                raise CheckpointError(f"{outdir}: nothing to restart from (no completed step in "
                                      f"{shown}; run without --restart)")
            self._take_lock()
            return manifest
        if exists or path.exists():
            if not overwrite:
                raise CheckpointError(f"{shown}: checkpoints of an earlier run of this output "
                                      f"folder exist: resume it with --restart, or start over "
                                      f"with --overwrite")
            if not path.is_dir() or path.is_symlink() or not (path / "README.txt").is_file():
                raise CheckpointError(f"{shown}: not a checkpoint folder of xfemcontact: "
                                      f"--overwrite replaces only checkpoints it wrote")
            self._take_lock()
            shutil.rmtree(path)
            _unlock(self._fd)
            self._fd = None
        return None

    def _take_lock(self) -> None:
        fd = _lock(self.path)
        if fd == -1:
            raise CheckpointError(f"{self.path}: another run is using these checkpoints")
        self._fd = fd

    def _read_manifest(self) -> dict[str, Any]:
        try:
            return json.loads((self.path / "manifest.json").read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise CheckpointError(f"{self.path}/manifest.json: cannot be read "
                                  f"({type(exc).__name__}): cannot restart") from None

    # -- the layout ---------------------------------------------------------------
    def fingerprint(self, model: Model) -> list[list[Any]]:
        """How the dofs are split over the processes (all processes; a list)."""
        mesh, layout = model.mesh, model.layout
        cells = hashlib.sha256(np.ascontiguousarray(mesh.cell_ids, dtype=np.int64).tobytes()).hexdigest()
        mine = [int(layout.global_size), int(layout.owned_size), int(layout.ownership_start), cells]
        return self.comm.allgather(mine)

    def check_layout(self, model: Model) -> None:
        """The dof layout of ``model`` is the one of the checkpoints (collective)."""
        if self.manifest is None:
            return
        if self.fingerprint(model) != self.manifest["layout"]:
            raise CheckpointError(f"{self.path}: the mesh was split over the processes "
                                  f"differently from the run that wrote the checkpoints: cannot "
                                  f"restart")

    # -- writing ------------------------------------------------------------------
    def _start(self, model: Model) -> None:
        if self._started:
            return
        if self.comm.rank == 0:
            self.path.mkdir(parents=True, exist_ok=True)
            if self._fd is None:
                self._take_lock()
            readme = README.format(case=self.case.source, out=self.path.name[:-len(SUFFIX)])
            _write_atomic(self.path / "README.txt", readme)
        self._layout = self.fingerprint(model)
        self.comm.barrier()
        self._started = True

    def save(self, model: Model, index: int, record: dict[str, Any], plan: dict[str, Any]) -> None:
        """Write completed step ``index`` (1-based): each process its solution and
        state, rank 0 the step record, then the manifest (``plan``: time, pending ...)."""
        self._start(model)
        rank, size = self.comm.rank, self.comm.size
        arrays = {"x": model.x.getArray(readonly=True).copy()}
        none: list[str] = []
        for key, value in model.problem.state().items() if model.problem is not None else ():
            if value is None:
                none.append(key)
            else:
                arrays["state." + key] = np.asarray(value)
        tangent = model.interface_tangent()
        if tangent is not None:
            arrays["K_int"] = tangent
        arrays["none"] = np.array(none, dtype="U64")
        name = self.path / f"step-{index:06d}.p{rank}-of-{size}.npz"
        tmp = name.with_name(name.name + ".part.npz")
        np.savez(tmp, **arrays)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, name)
        self.comm.barrier()
        if rank == 0:
            _write_atomic(self.path / f"step-{index:06d}.json", json.dumps(record, default=_plain))
            manifest = {"format": FORMAT, "written_by": "xfemcontact", "case_file": str(self.case.path),
                        "digest": case_digest(self.case), "processes": size, "layout": self._layout,
                        "completed": index, **plan}
            _write_atomic(self.path / "manifest.json", json.dumps(manifest, default=_plain, indent=1))
        self.comm.barrier()

    # -- reading ------------------------------------------------------------------
    def records(self) -> list[dict[str, Any]]:
        """The records of the completed steps (rank 0; [] elsewhere)."""
        if self.comm.rank != 0 or self.manifest is None:
            return []
        return [json.loads((self.path / f"step-{i:06d}.json").read_text(encoding="utf-8"))
                for i in range(1, self.manifest["completed"] + 1)]

    def load(self, model: Model, index: int) -> None:
        """Put the solution and state of step ``index`` into ``model`` (collective)."""
        name = self.path / f"step-{index:06d}.p{self.comm.rank}-of-{self.comm.size}.npz"
        with np.load(name, allow_pickle=False) as data:
            x = data["x"]
            tangent = data["K_int"] if "K_int" in data.files else None
            none = set(data["none"].tolist())
            state = {k[len("state."):]: data[k] for k in data.files if k.startswith("state.")}
        for key in none:
            state[key] = None
        model.x.setArray(x)
        if tangent is not None or model.interface_tangent() is not None:
            model.set_interface_tangent(tangent)
        if model.problem is not None and state:
            model.problem.set_state({k: (v.item() if v.ndim == 0 else v) if v is not None else None
                                     for k, v in state.items()})

    def remove(self) -> None:
        """After the results are written: the checkpoints are no longer needed."""
        if self.comm.rank == 0 and self.path.is_dir():
            shutil.rmtree(self.path, ignore_errors=True)
        self.release()

    def release(self) -> None:
        """Unlock the folder (kept for a restart)."""
        _unlock(self._fd)
        self._fd = None

    def describe(self) -> str | None:
        """Where the checkpoints are, for messages (None when none was written)."""
        if not self._started and self.manifest is None:
            return None
        return str(self.path)


def _unlock(fd: int | None) -> None:
    if fd is not None and fd >= 0:
        with contextlib.suppress(OSError):
            os.close(fd)


def _plain(obj: object) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot write {type(obj).__name__} to JSON")
