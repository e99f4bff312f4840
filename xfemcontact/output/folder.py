"""An output folder that is complete or absent, and never anything but ours.

Files are written into a hidden temporary folder next to the target
(``.NAME.tmp-PID``); on success it takes the target's place in one atomic step
(:meth:`OutputFolder.commit`).  On failure or interruption the temporary folder is
removed and the previous results, if any, are left untouched.  Only rank 0
touches the file system.

Before anything else (:class:`OutputFolder` at construction, before the mesh is
read) the location is checked: an existing target is replaced only with
``overwrite`` and only when it is a result folder xfemcontact wrote
(:func:`ours`: it carries the mark file :data:`MARK`, listing the files written,
and holds nothing else); the temporary folder is created (missing parents too),
written to and removed again, so a read-only, full or unreachable location, a
name too long or a parent that is a file are refused at once (exit code 2).
Temporary folders left by earlier runs that were killed (no process holds their
lock any more) are removed, and a previous result folder set aside by a
replacement that was cut short is put back.

The replacement: ``renameat2(RENAME_EXCHANGE)`` swaps the finished folder and the
target in one step (Linux 3.15+, on ext4, XFS, Btrfs, tmpfs ...), then the old
results are removed.  Where the file system cannot exchange, the old target is
renamed aside (``.NAME.old-PID``) and the new folder renamed into place: a crash
between the two leaves the old results complete under that name, and the next
run with the same target puts them back.  Files are flushed to disk (fsync)
before the swap, so a machine crash leaves the old or the new folder complete.

Interruptions: :func:`handle_signals` turns SIGINT, SIGTERM and SIGHUP into
:class:`~xfemcontact.errors.Interrupted`, raised in the main thread, and lets a
closed standard output raise ``BrokenPipeError`` (SIGPIPE ignored); the run aborts
its folder on the way up (:meth:`OutputFolder.abort`) and
:meth:`OutputFolder.outcome` says what is left.  A signal received while the
finished folder replaces the target is held back until the replacement is done.
"""
from __future__ import annotations

import contextlib
import ctypes
import errno
import fcntl
import json
import os
import re
import shutil
import signal
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterator

from xfemcontact.errors import CaseError, Interrupted

if TYPE_CHECKING:
    from types import FrameType

    from mpi4py import MPI

    from xfemcontact.output.plotter import PlotHelper

    #: a file or folder name as the callers give it
    PathName = str | os.PathLike[str]
    #: what ``signal.signal`` takes and returns
    SignalHandler = Callable[[int, FrameType | None], Any] | int | signal.Handlers | None

#: the signals :func:`handle_signals` turns into Interrupted
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
#: the mark of a result folder written by xfemcontact (JSON: who, version, files)
MARK = ".xfemcontact"
#: files of result folders written before the mark existed
LEGACY_FILES = ("results.json", "report.md", "interface.csv", "fields.xdmf", "fields.h5",
                "fields.vtu", "fields.med", "plot_multipliers.png", "plot_deformed.png",
                "plot_status.png", "plot_convergence.png")
#: free space below which an output location is refused at once (bytes)
MIN_FREE_BYTES = 1 << 20
_held: list[int] = []          # signals received inside a critical section
_critical = 0                  # depth of critical sections
_received: list[int] = []      # every signal received since handle_signals()


def _handler(signum: int, frame: FrameType | None) -> None:
    if _received:            # a second signal while stopping: stopping already
        return
    _received.append(signum)
    if _critical:
        _held.append(signum)
        return
    raise Interrupted(signum)


def handle_signals(reset: bool = True) -> dict[signal.Signals, SignalHandler]:
    """Install the SIGINT/SIGTERM/SIGHUP handlers and ignore SIGPIPE (main thread only;
    call again after PETSc starts, which installs its own); returns the previous ones.
    ``reset``: forget signals received before."""
    if reset:
        _received.clear()
        _held.clear()
    previous: dict[signal.Signals, SignalHandler] = {}
    wanted: list[tuple[signal.Signals, SignalHandler]] = [(s, _handler) for s in SIGNALS]
    for sig, handler in wanted + [(signal.SIGPIPE, signal.SIG_IGN)]:
        try:
            previous[sig] = signal.signal(sig, handler)
        except (ValueError, OSError):   # not the main thread: leave the defaults
            pass
    return previous


def restore_signals(previous: dict[signal.Signals, SignalHandler]) -> None:
    for sig, handler in previous.items():
        if handler is not None:
            signal.signal(sig, handler)


@contextlib.contextmanager
def critical() -> Iterator[None]:
    """Hold SIGINT/SIGTERM/SIGHUP back inside the block; raise Interrupted after it if one came."""
    global _critical
    _critical += 1
    try:
        yield
    finally:
        _critical -= 1
    if not _critical and _held:
        raise Interrupted(_held.pop())


# --- what is ours ---------------------------------------------------------------------

def ours(path: PathName) -> tuple[bool, str]:
    """``(True, "")`` if ``path`` is a result folder xfemcontact wrote and holds nothing
    else (or an empty folder), else ``(False, why)``."""
    path = Path(path)
    try:
        entries = sorted(p.name for p in path.iterdir())
    except OSError as exc:
        return False, f"cannot be read ({exc.strerror})"
    if not entries:
        return True, ""
    listed: set[str] | None = None
    if MARK in entries:
        try:
            mark = json.loads((path / MARK).read_text(encoding="utf-8"))
            if mark.get("written_by") == "xfemcontact":
                listed = set(mark.get("files") or ()) | {MARK}
        except (OSError, ValueError, AttributeError, TypeError):
            listed = None
    elif "results.json" in entries:           # written before the mark existed
        try:
            with open(path / "results.json", "rb") as f:
                head = f.read(200)
            if re.match(rb'\s*\{\s*"xfemcontact"\s*:', head):    # its first key
                listed = set(LEGACY_FILES)
        except OSError:
            listed = None
    if listed is None:
        shown = ", ".join(_short(e) for e in entries[:3]) + (", ..." if len(entries) > 3 else "")
        return False, f"not a result folder of xfemcontact (it holds {shown})"
    extra = [e for e in entries if e not in listed]
    if extra:
        shown = ", ".join(_short(e) for e in extra[:3]) + (", ..." if len(extra) > 3 else "")
        return False, f"holds files xfemcontact did not write ({shown})"
    return True, ""


def _short(name: str, limit: int = 40) -> str:
    name = "".join(c if c.isprintable() else "?" for c in name)
    return name if len(name) <= limit else name[:limit - 3] + "..."


# --- atomic exchange ------------------------------------------------------------------------

_RENAME_NOREPLACE, _RENAME_EXCHANGE = 1, 2
_AT_FDCWD = -100


def _renameat2(src: PathName, dst: PathName, flags: int) -> None:
    """``renameat2(src, dst, flags)``; raises OSError (ENOSYS/EINVAL when unsupported)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        raise OSError(errno.ENOSYS, "renameat2 is not available") from None
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int
    if fn(_AT_FDCWD, os.fsencode(src), _AT_FDCWD, os.fsencode(dst), flags) != 0:
        code = ctypes.get_errno()
        raise OSError(code, os.strerror(code), str(src))


def exchange(a: PathName, b: PathName) -> None:
    """Swap the folders ``a`` and ``b`` atomically; OSError if the system cannot."""
    _renameat2(a, b, _RENAME_EXCHANGE)


_UNSUPPORTED = (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP)


def _fsync_tree(root: PathName) -> None:
    """Flush the files of ``root`` and the folder itself to disk."""
    for dirpath, _, files in os.walk(root):
        for name in files:
            with contextlib.suppress(OSError):
                fd = os.open(os.path.join(dirpath, name), os.O_RDONLY)
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)
        _fsync_dir(dirpath)


def _fsync_dir(path: PathName) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _lock(path: PathName) -> int | None:
    """An exclusive lock on folder ``path`` (an open descriptor), None if another holds it."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    return fd


def _unlock(fd: int | None) -> None:
    if fd is not None:
        with contextlib.suppress(OSError):
            os.close(fd)


def clean_stale(target: PathName) -> list[str]:
    """Remove the temporary folders of earlier runs on ``target`` that were killed, and put
    back a previous result folder set aside by a replacement cut short.  Returns the
    names removed or restored.  A folder some running process holds (its lock) is left."""
    target = Path(target)
    done: list[str] = []
    try:
        siblings = list(target.parent.iterdir()) if target.parent.is_dir() else []
    except OSError:
        return done
    for p in sorted(siblings):
        name = p.name
        for kind in (".tmp-", ".old-", ".probe-"):
            prefix = f".{target.name}{kind}"
            if not name.startswith(prefix) or not name[len(prefix):].isdigit() or p.is_symlink() \
                    or not p.is_dir():
                continue
            if kind == ".probe-" and _young(p):
                continue                     # another run is trying its location right now
            fd = _lock(p)
            if fd is None:                   # a running process owns it
                continue
            try:
                if not _made_by_us(p):
                    continue
                if kind == ".old-" and not os.path.lexists(target):
                    os.rename(p, target)     # the replacement was cut short: old results back
                    done.append(f"{name} -> {target.name}")
                else:
                    shutil.rmtree(p, ignore_errors=True)
                    done.append(name)
            except OSError:
                pass
            finally:
                _unlock(fd)
    return done


#: an empty temporary folder younger than this may be one a run has just made (s)
_YOUNG = 60.0


def _young(path: Path) -> bool:
    try:
        return time.time() - path.stat().st_mtime <= _YOUNG
    except OSError:
        return True


def _made_by_us(path: Path) -> bool:
    """Whether a leftover folder is ours: it has our mark (complete or being written),
    is a result folder of ours, or is empty and not new."""
    try:
        mark = json.loads((path / MARK).read_text(encoding="utf-8"))
        if isinstance(mark, dict) and mark.get("written_by") == "xfemcontact":
            return True
    except (OSError, ValueError):
        pass
    try:
        if not any(path.iterdir()):
            return not _young(path)
    except OSError:
        return False
    return ours(path)[0]


# --- the folder ------------------------------------------------------------------------

class OutputFolder:
    """The result folder of a run, written aside and swapped in (see the module documentation)."""

    def __init__(self, path: PathName, overwrite: bool = False, comm: MPI.Comm | None = None) -> None:
        """``comm``: an mpi4py communicator (rank 0 decides, everybody learns)."""
        self.path = Path(path)
        self.rank = comm.rank if comm is not None else 0
        self.size = comm.size if comm is not None else 1
        self.plot_helper: PlotHelper | None = None  # see start_plot_helper
        self.tmp = self.path.parent / f".{self.path.name}.tmp-{os.getpid()}"
        self.probe = self.path.parent / f".{self.path.name}.probe-{os.getpid()}"
        self._made: list[Path] = []          # folders we created (removed again on abort)
        self._lock: int | None = None
        self.committed = False
        self.cleaned: list[str] = []
        problem = self._problem(overwrite) if self.rank == 0 else None
        if comm is not None and comm.size > 1:
            problem = comm.bcast(problem, root=0)
        if problem:
            raise CaseError(problem)

    def _problem(self, overwrite: bool) -> str | None:
        """What is wrong with the location (one line), or None; checks it can be written."""
        shown = _short(str(self.path), 200)
        if self.path.parent.is_dir():    # before anything: a replacement cut short is undone
            self.cleaned = clean_stale(self.path)
        try:
            name = self.path.resolve().name if self.path.name in ("", ".", "..") else self.path.name
        except OSError:
            name = self.path.name
        if self.path.name in ("", ".", ".."):
            # "-o ." names the folder itself: never a folder we would replace in place
            exists = self.path.exists()
            if exists and not overwrite:
                return (f"{shown}: output folder exists (use --overwrite to replace it, "
                        f"or -o to choose another)")
            if exists:
                ok, why = ours(self.path)
                if not ok:
                    return (f"{shown}: {why}: --overwrite replaces only result folders "
                            f"xfemcontact wrote (choose another -o)")
                return f"{shown}: give the result folder by its name, not as '{self.path.name}'"
        try:
            limit = os.pathconf(self._existing_parent(), "PC_NAME_MAX")
        except (OSError, ValueError):
            limit = 255
        room = limit - len(f"..probe-{os.getpid()}")
        if len(os.fsencode(name)) > room:
            return (f"{_short(name, 60)}: output folder name too long "
                    f"({len(os.fsencode(name))} bytes; at most {room} here)")
        if self.path.is_symlink():
            return f"{shown}: is a symbolic link (give the folder itself with -o)"
        if self.path.exists() and not self.path.is_dir():
            return f"{shown}: exists and is not a folder"
        if self.path.exists():
            if not overwrite:
                return (f"{shown}: output folder exists (use --overwrite to replace it, "
                        f"or -o to choose another)")
            ok, why = ours(self.path)
            if not ok:
                return (f"{shown}: {why}: --overwrite replaces only result folders "
                        f"xfemcontact wrote (move what you keep there, or choose another -o)")
        return self._probe()

    def _existing_parent(self) -> Path:
        p = self.path.absolute().parent
        while not p.exists() and p != p.parent:
            p = p.parent
        return p

    def _probe(self) -> str | None:
        """Create the temporary folder (and missing parents), write to it, remove it all:
        the location is writable now.  A message, or None."""
        made: list[Path] = []
        try:
            parent = self._existing_parent()
            if not parent.is_dir():
                return f"{_short(str(self.path), 200)}: cannot create the output folder: " \
                       f"{_short(str(parent), 100)} is not a folder"
            missing = [p for p in reversed(self.probe.absolute().parents) if not p.exists()]
            for p in missing:
                p.mkdir()
                made.append(p)
            self.probe.mkdir()
            made.append(self.probe)
            with open(self.probe / MARK, "w", encoding="utf-8") as f:
                f.write('{"written_by": "xfemcontact", "files": []}\n')
                f.flush()
                os.fsync(f.fileno())
            stats = os.statvfs(self.probe)
            if stats.f_bavail * stats.f_frsize < MIN_FREE_BYTES:
                return (f"{_short(str(self.path), 200)}: no room for results "
                        f"({stats.f_bavail * stats.f_frsize / 1e6:.2g} MB free)")
        except OSError as exc:
            where = exc.filename and Path(exc.filename)
            at = f" ({_short(str(where), 120)})" if where and where != self.path and \
                where.name not in (self.probe.name, MARK) else ""
            return (f"{_short(str(self.path), 200)}: cannot create the output folder: "
                    f"{exc.strerror or exc}{at}")
        finally:
            with contextlib.suppress(OSError):
                if self.probe in made:
                    shutil.rmtree(self.probe, ignore_errors=True)
                for p in reversed(made[:-1] if self.probe in made else made):
                    p.rmdir()
        return None

    def _start(self) -> None:
        if self._made:
            return
        with critical():         # what we create is recorded before a signal can stop us
            missing = [p for p in reversed(self.path.parents) if not p.exists()]
            for p in missing:
                p.mkdir()
            shutil.rmtree(self.tmp, ignore_errors=True)
            self.tmp.mkdir()
            self._made = missing + [self.tmp]
            self._lock = _lock(self.tmp)       # held until the end: not stale
            (self.tmp / MARK).write_text('{"written_by": "xfemcontact", "files": []}\n',
                                         encoding="utf-8")

    def start_plot_helper(self, idle_ranks: int = 0) -> PlotHelper | None:
        """Start the processes that will draw the plots into this folder (rank 0; see
        :mod:`xfemcontact.output.plotter`; ``idle_ranks``: processes of the run on this
        machine that will wait without spinning) and return them (None elsewhere); the
        same ones when called again, unless none could start before.  Stopped by
        :meth:`abort`."""
        if self.rank == 0 and (self.plot_helper is None or (idle_ranks and not self.plot_helper.procs)):
            from xfemcontact.output.plotter import PlotHelper

            self.plot_helper = PlotHelper.start(self.size, idle_ranks)
        return self.plot_helper

    def stop_plot_helper(self) -> None:
        if self.plot_helper is not None:
            self.plot_helper.stop()

    def file(self, name: str) -> Path:
        """Path of ``name`` inside the folder being written (created on first use)."""
        self._start()
        return self.tmp / name

    def write_text(self, name: str, text: str) -> None:
        if self.rank == 0:
            self.file(name).write_text(text, encoding="utf-8")

    def write_json(self, name: str, obj: object) -> None:
        """Strict JSON: NaN and infinities (a test that selected no point) become null."""
        if self.rank == 0:
            text = json.dumps(_strict(obj), indent=1, default=_jsonable, allow_nan=False)
            self.file(name).write_text(text + "\n", encoding="utf-8")

    def _write_mark(self) -> None:
        from xfemcontact import __version__

        files = sorted(p.name for p in self.tmp.iterdir() if p.name != MARK)
        mark = {"written_by": "xfemcontact", "version": __version__, "files": files}
        (self.tmp / MARK).write_text(json.dumps(mark) + "\n", encoding="utf-8")

    def commit(self) -> None:
        """Replace the target by the finished folder (signals held back meanwhile)."""
        if self.rank != 0:
            self.committed = True
            return
        self._start()
        with critical():
            self._write_mark()
            _fsync_tree(self.tmp)
            if os.path.lexists(self.path):
                ok, why = ours(self.path) if self.path.is_dir() and not self.path.is_symlink() \
                    else (False, "is not a folder")
                if not ok:
                    raise CaseError(f"{self.path}: {why} (it appeared while the case was "
                                    f"solved; the new results are not kept)")
                self._replace()
            else:
                try:
                    _renameat2(self.tmp, self.path, _RENAME_NOREPLACE)
                except OSError as exc:
                    if exc.errno not in _UNSUPPORTED:
                        raise
                    os.rename(self.tmp, self.path)
            self.committed = True
            _fsync_dir(self.path.parent)
            _unlock(self._lock)
            self._lock = None
            shutil.rmtree(self.tmp, ignore_errors=True)     # the old results, if exchanged

    def _replace(self) -> None:
        """The finished folder in the target's place, the old one at ``self.tmp`` (removed
        after) or set aside."""
        try:
            exchange(self.tmp, self.path)
            return
        except OSError as exc:
            if exc.errno not in _UNSUPPORTED:
                raise
        old = self.path.parent / f".{self.path.name}.old-{os.getpid()}"
        os.rename(self.path, old)
        _fsync_dir(self.path.parent)
        os.rename(self.tmp, self.path)        # a crash before this: the next run puts old back
        _fsync_dir(self.path.parent)
        shutil.rmtree(old, ignore_errors=True)

    def outcome(self) -> str:
        """What the target holds now, in words (for the message of an interrupted run)."""
        if self.committed:
            return f"complete results in {self.path} (the run had finished)"
        if self.path.is_dir():
            return f"previous results in {self.path} kept"
        return "no results written"

    def abort(self) -> None:
        """Remove the temporary folder (and the parents we made); the target is untouched."""
        self.stop_plot_helper()
        if self.rank != 0 or not self._made or self.committed:
            return
        with critical():
            shutil.rmtree(self.tmp, ignore_errors=True)
            _unlock(self._lock)
            self._lock = None
            for p in reversed(self._made[:-1]):      # parents we made, if still empty
                try:
                    p.rmdir()
                except OSError:
                    break
            self._made = []


def _strict(obj: Any) -> Any:
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


def _jsonable(obj: object) -> Any:
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
