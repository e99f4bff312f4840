"""The PNG plots drawn by a helper process while the run writes its other files.

Drawing the four plots takes matplotlib most of a second, plus 0.3 s to import it.
When the machine has a core the run does not use (one process on a 2-core
machine), rank 0 starts a helper Python process when the output phase begins
(:meth:`PlotHelper.start`): it imports matplotlib while the run gathers the
interface table, and draws the plots that need only that table and the
iteration record while the run builds the post-processing mesh and writes
fields.xdmf; then the deformed mesh (as the image or polygons
:func:`~xfemcontact.post.plots.deformed_data` reduced it to) and the statuses.
The run waits for it before report.md (:meth:`PlotHelper.finish`).  On large runs
it is not started earlier on purpose: during the factorisation it would hold about
45 MB (Python, NumPy, matplotlib) for nothing; on runs estimated below
:data:`xfemcontact.run.EARLY_PLOTS_MB` it starts before the solve, which hides the
import of matplotlib.

Whatever goes wrong with the helper (it could not start, died, reported an
error), the plots it did not confirm are drawn by the run itself: the files are
the same either way.  The helper reads its jobs from a pipe and leaves when the
pipe closes, so it never outlives the run; it ignores SIGINT (the run handles
interruptions and closes the pipe).
"""
from __future__ import annotations

import importlib
import os
import pickle
import subprocess
import sys
from typing import TYPE_CHECKING, Iterable, Sequence

if TYPE_CHECKING:
    import threading

    from xfemcontact.post.plots import Job
    #: a file or folder name as the callers give it
    PathName = str | os.PathLike[str]

#: seconds the run waits for the helper's answer before drawing the plots itself
TIMEOUT = 120.0


def spare_core(comm_size: int) -> bool:
    """True when this machine has more cores than the run has processes."""
    return (os.cpu_count() or 1) > comm_size


class PlotHelper:
    """A helper process drawing plots (see the module docstring); rank 0 only."""

    def __init__(self) -> None:
        self.proc: subprocess.Popen[bytes] | None = None
        self.jobs: list[Job] = []                      # the jobs sent
        self._writers: list[threading.Thread] = []     # threads writing to the helper's pipe
        self.times: dict[str, float] = {}              # the helper's CPU seconds: "import", and per PNG

    @property
    def sent(self) -> list[str]:
        """Names of the PNGs sent."""
        return [name for name, _, _ in self.jobs]

    @classmethod
    def start(cls, comm_size: int = 1) -> PlotHelper:
        """A started helper, or one that is not running (then :meth:`send` refuses
        and the caller draws the plots itself)."""
        helper = cls()
        if not spare_core(comm_size):
            return helper
        try:
            helper.proc = subprocess.Popen(
                [sys.executable, "-c", "from xfemcontact.output.plotter import serve; serve()"],
                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, close_fds=True)
        except OSError:
            helper.proc = None
        return helper

    @property
    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def send(self, jobs: Sequence[Job], folder_path: PathName) -> bool:
        """Hand ``jobs`` [(png name, plots function name, args)] to the helper, to be
        written into ``folder_path``; False (nothing sent) when it is not running."""
        if not self.running or not jobs:
            return False
        try:
            data = pickle.dumps((str(folder_path), jobs), protocol=pickle.HIGHEST_PROTOCOL)
        except (pickle.PicklingError, TypeError, AttributeError):
            return False
        # the helper reads only once matplotlib is imported: a thread waits on the pipe
        # (the interpreter lock is released while it blocks), this process goes on
        import threading

        assert self.proc is not None and self.proc.stdin is not None      # running, on a pipe
        stdin = self.proc.stdin

        def write() -> None:
            try:
                stdin.write(data)
                stdin.flush()
            except (OSError, ValueError):
                pass                     # the helper died: finish() finds its jobs missing

        writer = threading.Thread(target=write, daemon=True)
        writer.start()
        self._writers.append(writer)
        self.jobs += list(jobs)
        return True

    def finish(self, timeout: float = TIMEOUT) -> list[str]:
        """Wait for the helper; returns the names of the PNGs it wrote.  Its CPU times
        (import, each plot) are left in :attr:`times`."""
        if self.proc is None:
            return []
        for writer in self._writers:
            writer.join()
        try:
            out, _ = self.proc.communicate(timeout=timeout)     # closes the helper's stdin first
            done, self.times = pickle.loads(out) if out else ([], {})
        except Exception:            # timeout, crash, garbage on the pipe: draw them ourselves
            self.stop()
            return []
        self.proc = None
        return [name for name in done if name in self.sent]

    def stop(self) -> None:
        """End the helper at once (abort, or after it failed)."""
        if self.proc is None:
            return
        try:
            self.proc.kill()
            self.proc.wait(timeout=5)
        except Exception:
            pass
        for writer in self._writers:     # the pipe is broken now: they return
            writer.join(timeout=5)
        self.proc = None


def run_jobs(jobs: Iterable[Job], folder_path: PathName, times: dict[str, float] | None = None) -> list[str]:
    """Draw ``jobs`` into ``folder_path``; returns the names written (CPU seconds of
    each into ``times``)."""
    import time

    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from xfemcontact.post import plots

    done: list[str] = []
    for name, function, args in jobs:
        t0 = time.process_time()
        fig = plots.figure_function(function)(*args)
        FigureCanvasAgg(fig)             # the figure is drawn once, by savefig
        fig.savefig(os.path.join(folder_path, name), **plots.SAVE_OPTIONS)
        done.append(name)
        if times is not None:
            times[name] = round(time.process_time() - t0, 4)
    return done


def serve() -> None:
    """The helper's main: import matplotlib, then draw every batch of jobs that comes
    on stdin until it closes; answer with the list of PNGs written."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        os.sched_setaffinity(0, range(os.cpu_count() or 1))    # not bound to the run's core
    except (AttributeError, OSError):
        pass
    import time

    t0 = time.process_time()
    import matplotlib

    matplotlib.use("Agg")
    importlib.import_module("matplotlib.backends.backend_agg")    # imported now, used later
    from matplotlib.figure import Figure

    importlib.import_module("xfemcontact.post.plots")

    Figure()                             # fonts and rc parameters loaded before the data comes
    times = {"import": round(time.process_time() - t0, 4)}
    done: list[str] = []
    stdin = sys.stdin.buffer
    while True:
        try:
            folder, jobs = pickle.load(stdin)
        except EOFError:
            break
        except Exception:
            break
        try:
            done += run_jobs(jobs, folder, times)
        except Exception:
            break
    try:
        sys.stdout.buffer.write(pickle.dumps((done, times)))
        sys.stdout.buffer.flush()
    except OSError:
        pass
