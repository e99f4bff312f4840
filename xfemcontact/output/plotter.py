"""The PNG plots drawn by helper processes while the run writes its other files.

Drawing the four plots takes matplotlib 0.5 - 0.7 s of CPU, plus 0.3 s to import
it.  Rank 0 starts up to :data:`HELPERS` helper Python processes
(:meth:`PlotHelper.start`):

* on a machine with a core the run does not use (one process on a 2-core machine),
  when the run starts: they import matplotlib one after the other on that core while
  the run builds and solves its model.  Whatever the run's size: the run keeps its
  peak memory to its end (glibc does not trim, see
  :func:`xfemcontact.timing.release_heap`), so a helper beside it (60 MB resident,
  38 MB of its own) raises the machine's peak as much whenever it starts;
* on several processes, when the output phase begins, on the cores of the other
  processes of rank 0's machine: those wait without spinning
  (:func:`xfemcontact.output.results.wait_quietly`) until rank 0 is done.

The jobs are dealt to the helpers in turn: first the plots that need only the
interface table and the iteration record, drawn while the run builds the
post-processing mesh; then the statuses and the deformed mesh (as the image or
polygons :func:`~xfemcontact.post.plots.deformed_data` reduced it to), drawn while
the run writes fields.xdmf.  The run waits for them before report.md
(:meth:`PlotHelper.finish`).

Whatever goes wrong with a helper (it could not start, died, reported an error),
the plots not confirmed are drawn by the run itself: the files are the same either
way.  A helper reads its jobs from a pipe and leaves when the pipe closes, so it
never outlives the run; it ignores SIGINT (the run handles interruptions and closes
the pipe).
"""
from __future__ import annotations

import importlib
import os
import pickle
import subprocess
import sys
from typing import IO, TYPE_CHECKING, Iterable, Sequence

if TYPE_CHECKING:
    import threading

    from xfemcontact.post.plots import Job
    #: a file or folder name as the callers give it
    PathName = str | os.PathLike[str]

#: seconds the run waits for the helpers' answers before drawing the plots itself
TIMEOUT = 120.0
#: helper processes at most: the 2-D run has four plots, two helpers draw two each
HELPERS = 2


def spare_core(comm_size: int) -> bool:
    """True when this machine has more cores than the run has processes."""
    return (os.cpu_count() or 1) > comm_size


class PlotHelper:
    """Helper processes drawing plots (see the module docstring); rank 0 only.

    With several helpers the jobs are dealt in turn (the first job to the first
    helper, the second to the second, ...), over every :meth:`send`."""

    def __init__(self) -> None:
        self.procs: list[subprocess.Popen[bytes]] = []
        self.jobs: list[Job] = []                      # the jobs sent
        self._writers: list[threading.Thread] = []     # threads writing to the helpers' pipes
        self.times: dict[str, float] = {}              # the helpers' CPU seconds: "import" (the longest), and per PNG

    @property
    def sent(self) -> list[str]:
        """Names of the PNGs sent."""
        return [name for name, _, _ in self.jobs]

    @classmethod
    def start(cls, comm_size: int = 1, idle_ranks: int = 0) -> PlotHelper:
        """Started helpers, or none (then :meth:`send` refuses and the caller draws the
        plots itself).  They start where the machine has a core the run does not use,
        or ``idle_ranks`` processes of the run on this machine that wait without
        spinning while the helpers draw (:func:`xfemcontact.output.results.wait_quietly`),
        up to :data:`HELPERS` of them: one per free core, and one more for this process's
        own core when they start with the run (this process then waits while they
        draw; with the outputs it builds the post mesh while they import matplotlib: a
        second helper on two processes made that slower, QUAD8 320 output 1.02 - 1.09 s
        with one helper, 1.31 - 1.36 s with two)."""
        helper = cls()
        if not (spare_core(comm_size) or idle_ranks > 0):
            return helper
        free = (os.cpu_count() or 1) - comm_size + idle_ranks
        count = max(1, min(HELPERS, free + 1 if idle_ranks == 0 else free))
        # the helpers import matplotlib one after the other, so that they take one core
        # and leave the run its own: each waits for the end of a pipe that the one before
        # closes once it has imported (or dies)
        wait = -1
        for k in range(count):
            done_r, done_w = os.pipe() if k + 1 < count else (-1, -1)
            fds = tuple(fd for fd in (wait, done_w) if fd >= 0)
            try:
                helper.procs.append(subprocess.Popen(
                    [sys.executable, "-c", "from xfemcontact.output.plotter import serve; serve()",
                     str(wait), str(done_w)],
                    stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                    close_fds=True, pass_fds=fds))
            except OSError:
                for fd in (done_r, done_w):
                    if fd >= 0:
                        os.close(fd)
                break
            for fd in fds:                   # the helper's ends
                os.close(fd)
            wait = done_r
        else:
            return helper
        if wait >= 0:                        # a helper could not start: nobody waits on this
            os.close(wait)
        return helper

    @property
    def running(self) -> bool:
        return bool(self.procs) and all(p.poll() is None for p in self.procs)

    def send(self, jobs: Sequence[Job], folder_path: PathName) -> bool:
        """Hand ``jobs`` [(png name, plots function name, args)] to the helpers, to be
        written into ``folder_path``; False (nothing sent) when they are not running."""
        if not self.running or not jobs:
            return False
        turn = len(self.jobs)
        batches: list[list[Job]] = [[] for _ in self.procs]
        for k, job in enumerate(jobs):
            batches[(turn + k) % len(self.procs)].append(job)
        try:
            data = [pickle.dumps((str(folder_path), batch), protocol=pickle.HIGHEST_PROTOCOL)
                    for batch in batches]
        except (pickle.PicklingError, TypeError, AttributeError):
            return False
        # a helper reads only once matplotlib is imported: a thread waits on each pipe
        # (the interpreter lock is released while it blocks), this process goes on
        import threading

        for proc, batch, message in zip(self.procs, batches, data):
            if not batch:
                continue
            assert proc.stdin is not None      # started on a pipe
            writer = threading.Thread(target=_write, args=(proc.stdin, message), daemon=True)
            writer.start()
            self._writers.append(writer)
        self.jobs += list(jobs)
        return True

    def finish(self, timeout: float = TIMEOUT) -> list[str]:
        """Wait for the helpers; returns the names of the PNGs they wrote.  Their CPU
        times (import, each plot) are left in :attr:`times`."""
        if not self.procs:
            return []
        for writer in self._writers:
            writer.join()
        done: list[str] = []
        try:
            for proc in self.procs:
                out, _ = proc.communicate(timeout=timeout)     # closes the helper's stdin first
                names, times = pickle.loads(out) if out else ([], {})
                done += names
                for key, cpu in times.items():
                    self.times[key] = max(cpu, self.times.get(key, 0.0))
        except Exception:            # timeout, crash, garbage on a pipe: draw them ourselves
            self.stop()
            return []
        self.procs = []
        return [name for name in done if name in self.sent]

    def stop(self) -> None:
        """End the helpers at once (abort, or after one failed)."""
        for proc in self.procs:
            try:
                proc.kill()
                proc.wait(timeout=5)
            except Exception:
                pass
        for writer in self._writers:     # the pipes are broken now: they return
            writer.join(timeout=5)
        self.procs = []


def _write(stdin: IO[bytes], data: bytes) -> None:
    try:
        stdin.write(data)
        stdin.flush()
    except (OSError, ValueError):
        pass                     # the helper died: finish() finds its jobs missing


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
    wait_fd, done_fd = (int(a) for a in sys.argv[1:3]) if len(sys.argv) >= 3 else (-1, -1)
    if wait_fd >= 0:                     # the helper before is importing: wait for it
        try:
            while os.read(wait_fd, 1):
                pass
        except OSError:
            pass
        os.close(wait_fd)
    import time

    t0 = time.process_time()
    import matplotlib

    matplotlib.use("Agg")
    importlib.import_module("matplotlib.backends.backend_agg")    # imported now, used later
    from matplotlib.figure import Figure

    importlib.import_module("xfemcontact.post.plots")

    Figure()                             # fonts and rc parameters loaded before the data comes
    times = {"import": round(time.process_time() - t0, 4)}
    if done_fd >= 0:
        os.close(done_fd)                # the next helper may import now
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
    # the PNGs are closed: leave without tearing matplotlib down (0.1 s the run would wait)
    os._exit(0)
