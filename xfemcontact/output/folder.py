"""An output folder that is complete or absent.

Files are written into a hidden temporary folder next to the target; on
success it replaces the target in one rename (an existing target is only
replaced with ``overwrite``).  On failure or interruption the temporary folder
is removed and the previous results, if any, are left untouched.  Only rank 0
touches the file system.

Interruptions: :func:`handle_signals` turns SIGINT and SIGTERM into
:class:`~xfemcontact.errors.Interrupted`, raised in the main thread; the run
aborts its folder on the way up (:meth:`OutputFolder.abort`) and
:meth:`OutputFolder.outcome` says what is left.  A signal received while the
finished folder replaces the target (:meth:`OutputFolder.commit`, two renames)
is held back until both renames are done, so that the target is always either
the complete previous results or the complete new ones.
"""
import contextlib
import json
import os
import shutil
import signal
from pathlib import Path

from xfemcontact.errors import CaseError, Interrupted

#: the signals :func:`handle_signals` catches
SIGNALS = (signal.SIGINT, signal.SIGTERM)
_held = []           # signals received inside a critical section
_critical = 0        # depth of critical sections
_received = []       # every signal received since handle_signals()


def _handler(signum, frame):
    if _received:            # a second signal while stopping: stopping already
        return
    _received.append(signum)
    if _critical:
        _held.append(signum)
        return
    raise Interrupted(signum)


def handle_signals():
    """Install the SIGINT/SIGTERM handlers (main thread only); returns the previous ones."""
    _received.clear()
    _held.clear()
    previous = {}
    for sig in SIGNALS:
        try:
            previous[sig] = signal.signal(sig, _handler)
        except ValueError:   # not the main thread: leave the defaults
            pass
    return previous


def restore_signals(previous):
    for sig, handler in previous.items():
        signal.signal(sig, handler)


@contextlib.contextmanager
def critical():
    """Hold SIGINT/SIGTERM back inside the block; raise Interrupted after it if one came."""
    global _critical
    _critical += 1
    try:
        yield
    finally:
        _critical -= 1
    if not _critical and _held:
        raise Interrupted(_held.pop())


class OutputFolder:
    def __init__(self, path, overwrite=False, comm=None):
        """``comm``: an mpi4py communicator (rank 0 decides, everybody learns)."""
        self.path = Path(path)
        self.rank = comm.rank if comm is not None else 0
        self.tmp = self.path.parent / f".{self.path.name}.tmp-{os.getpid()}"
        self._made = []          # folders we created (removed again on abort)
        self.committed = False
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
        with critical():         # what we create is recorded before a signal can stop us
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
        """Strict JSON: NaN and infinities (a test that selected no point) become null."""
        if self.rank == 0:
            text = json.dumps(_strict(obj), indent=1, default=_jsonable, allow_nan=False)
            self.file(name).write_text(text + "\n", encoding="utf-8")

    def commit(self):
        """Replace the target by the finished folder (signals held back meanwhile)."""
        if self.rank != 0:
            self.committed = True
            return
        self._start()
        old = None
        with critical():
            if self.path.exists():
                old = self.path.parent / f".{self.path.name}.old-{os.getpid()}"
                self.path.rename(old)
            self.tmp.rename(self.path)
            self.committed = True
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)

    def outcome(self):
        """What the target holds now, in words (for the message of an interrupted run)."""
        if self.committed:
            return f"complete results in {self.path} (the run had finished)"
        if self.path.is_dir():
            return f"previous results in {self.path} kept"
        return "no results written"

    def abort(self):
        """Remove the temporary folder (and the parents we made); the target is untouched."""
        if self.rank != 0 or not self._made or self.committed:
            return
        with critical():
            shutil.rmtree(self.tmp, ignore_errors=True)
            for p in reversed(self._made[:-1]):      # parents we made, if still empty
                try:
                    p.rmdir()
                except OSError:
                    break
            self._made = []


def _strict(obj):
    """``obj`` with non-finite floats (Python or NumPy, in containers and arrays) as None."""
    import math

    import numpy as np

    if isinstance(obj, dict):
        return {k: _strict(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_strict(v) for v in obj]
    if isinstance(obj, np.ndarray) and obj.dtype.kind == "f" and not np.isfinite(obj).all():
        return _strict(obj.tolist())
    if isinstance(obj, (float, np.floating)) and not math.isfinite(obj):
        return None
    return obj


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
