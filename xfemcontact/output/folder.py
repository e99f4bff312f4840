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
    def __init__(self, path, overwrite=False, rank=0):
        self.path = Path(path)
        self.rank = rank
        self.tmp = self.path.parent / f".{self.path.name}.tmp-{os.getpid()}"
        if rank != 0:
            return
        if self.path.exists() and not overwrite:
            raise CaseError(f"{self.path}: output folder exists (use --overwrite to replace it, "
                            f"or -o to choose another)")
        if self.path.exists() and not self.path.is_dir():
            raise CaseError(f"{self.path}: exists and is not a folder")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        shutil.rmtree(self.tmp, ignore_errors=True)
        self.tmp.mkdir()

    def file(self, name):
        """Path of ``name`` inside the folder being written."""
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
        old = None
        if self.path.exists():
            old = self.path.parent / f".{self.path.name}.old-{os.getpid()}"
            self.path.rename(old)
        self.tmp.rename(self.path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)

    def abort(self):
        if self.rank == 0:
            shutil.rmtree(self.tmp, ignore_errors=True)


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
