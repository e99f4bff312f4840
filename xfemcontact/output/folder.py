"""An output folder that is complete or absent.

Files are written into a hidden temporary folder next to the target; on
success it replaces the target in one rename (an existing target is only
replaced with ``overwrite``).  On failure or interruption the temporary folder
is removed and the previous results, if any, are left untouched.  Only rank 0
touches the file system.
"""
import json
import os
import shutil
from pathlib import Path

from xfemcontact.errors import CaseError


class OutputFolder:
    def __init__(self, path, overwrite=False, comm=None):
        """``comm``: an mpi4py communicator (rank 0 decides, everybody learns)."""
        self.path = Path(path)
        self.rank = comm.rank if comm is not None else 0
        self.tmp = self.path.parent / f".{self.path.name}.tmp-{os.getpid()}"
        self._made = []          # folders we created (removed again on abort)
        problem = self._problem(overwrite) if self.rank == 0 else None
        if comm is not None and comm.size > 1:
            problem = comm.bcast(problem, root=0)
        if problem:
            raise CaseError(problem)

    def _problem(self, overwrite):
        if self.path.exists() and not self.path.is_dir():
            return f"{self.path}: exists and is not a folder"
        if self.path.exists() and not overwrite:
            return (f"{self.path}: output folder exists (use --overwrite to replace it, "
                    f"or -o to choose another)")
        return None

    def _start(self):
        if self._made:
            return
        missing = [p for p in reversed(self.path.parents) if not p.exists()]
        for p in missing:
            p.mkdir()
        shutil.rmtree(self.tmp, ignore_errors=True)
        self.tmp.mkdir()
        self._made = missing + [self.tmp]

    def file(self, name):
        """Path of ``name`` inside the folder being written (created on first use)."""
        self._start()
        return self.tmp / name

    def write_text(self, name, text):
        if self.rank == 0:
            self.file(name).write_text(text, encoding="utf-8")

    def write_json(self, name, obj):
        if self.rank == 0:
            self.file(name).write_text(json.dumps(obj, indent=1, default=_jsonable) + "\n", encoding="utf-8")

    def commit(self):
        """Replace the target by the finished folder."""
        if self.rank != 0:
            return
        self._start()
        old = None
        if self.path.exists():
            old = self.path.parent / f".{self.path.name}.old-{os.getpid()}"
            self.path.rename(old)
        self.tmp.rename(self.path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)

    def abort(self):
        if self.rank != 0 or not self._made:
            return
        shutil.rmtree(self.tmp, ignore_errors=True)
        for p in reversed(self._made[:-1]):      # parents we made, if still empty
            try:
                p.rmdir()
            except OSError:
                break


def _jsonable(obj):
    import numpy as np

    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        return float(obj)
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot write {type(obj).__name__} to JSON")
