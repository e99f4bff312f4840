"""Phase timing: one PETSc log event per phase, wall times and memory for results.json.

``with phase("assembly"):`` opens the PETSc log event ``XFC:assembly`` (visible in
``-log_view``), adds the elapsed wall time to :data:`TIMINGS` (seconds) and
records this process's memory at the end of the phase in :data:`MEMORY`: the
resident size (``VmRSS``) and the peak resident size so far (``VmHWM``), MB.
The peak of a phase is the first phase-end peak that exceeds the previous one.

``with step("output:plots"):`` does the same for a part of a phase (its own
PETSc event ``XFC:output:plots``, wall time in :data:`STEPS`), for the
"where the time goes" figures of the bench.
"""
import time
from contextlib import contextmanager

from xfemcontact._petsc import PETSc

TIMINGS = {}
#: seconds spent in the parts of phases (``step``), by name
STEPS = {}
#: memory at the end of each phase (the last time it ended): name -> (rss MB, peak MB)
MEMORY = {}
_EVENTS = {}


def event(name):
    """Return (creating once) the PETSc log event ``XFC:name``."""
    if name not in _EVENTS:
        _EVENTS[name] = PETSc.Log.Event(f"XFC:{name}")
    return _EVENTS[name]


@contextmanager
def phase(name):
    ev = event(name)
    ev.begin()
    t0 = time.perf_counter()
    try:
        yield
    finally:
        TIMINGS[name] = TIMINGS.get(name, 0.0) + time.perf_counter() - t0
        MEMORY[name] = memory_now()
        ev.end()


@contextmanager
def step(name):
    """Time a part of a phase (see the module docstring)."""
    ev = event(name)
    ev.begin()
    t0 = time.perf_counter()
    try:
        yield
    finally:
        STEPS[name] = STEPS.get(name, 0.0) + time.perf_counter() - t0
        ev.end()


def reset():
    TIMINGS.clear()
    STEPS.clear()
    MEMORY.clear()


def memory_now():
    """``(rss, peak)``: this process's resident and peak resident memory, MB
    (``VmRSS`` and ``VmHWM`` of /proc/self/status; the peak from getrusage elsewhere)."""
    rss = peak = None
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    rss = int(line.split()[1]) / 1024.0
                elif line.startswith("VmHWM:"):
                    peak = int(line.split()[1]) / 1024.0
    except OSError:
        pass
    if peak is None:
        import resource

        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return (round(rss if rss is not None else peak, 1), round(peak, 1))


def phase_memory(comm):
    """Memory at the end of every phase that ran, for every process:
    ``{phase: {"rss_mb": [per process], "peak_mb": [per process]}}`` (collective)."""
    mpi = comm.tompi4py()
    every = mpi.allgather(dict(MEMORY))
    names = list(MEMORY)
    return {k: {"rss_mb": [m.get(k, (None, None))[0] for m in every],
                "peak_mb": [m.get(k, (None, None))[1] for m in every]} for k in names}


#: PETSc events reported in results.json: MUMPS analysis (symbolic), factorisation,
#: solves, and the SNES callbacks
SOLVER_EVENTS = ("MatLUFactorSym", "MatLUFactorNum", "MatCholFctrSym", "MatCholFctrNum",
                 "MatSolve", "SNESFunctionEval", "SNESJacobianEval", "MatAssemblyEnd")


def start_logging():
    """Turn PETSc's event logging on (cheap) so that solver phases can be reported."""
    PETSc.Log.begin()


def solver_events(comm):
    """Count and wall time (max over processes, s) of :data:`SOLVER_EVENTS` that ran."""
    mpi = comm.tompi4py()
    out = {}
    for name in SOLVER_EVENTS:
        info = PETSc.Log.Event(name).getPerfInfo()
        t = mpi.allreduce(info["time"], op=_mpi_max())
        if info["count"]:
            out[name] = {"count": int(info["count"]), "time": round(t, 4)}
    return out


def peak_memory_mb(comm):
    """Peak resident memory of every process, MB (VmHWM, as the phases')."""
    return comm.tompi4py().allgather(memory_now()[1])


def release_heap():
    """Give the memory freed by the set-up's temporaries back to the system: the
    factorisation that follows then raises the peak from a lower floor.  Collective.

    * PETSc objects: petsc4py 3.18 does not destroy a PETSc object when its Python
      object goes away, it only queues it until ``PETSc.garbage_cleanup()``
      (collective; at TRIA6 N = 320 that held 21 MB of a mesh transfer vector
      until the end of the run);
    * glibc keeps freed heap pages: ``malloc_trim`` (a no-op where it does not
      exist).  Debian's SuperLU_DIST, which PETSc loads, switches glibc's own
      trimming and its mmap of large blocks off (``mallopt``); that is kept: the
      second factorisation then reuses the pages of the first instead of faulting
      1.2 GB of fresh ones in again (TRIA6 N = 320: 1.3 s of system time), and
      this trim is the one moment memory is given back.
    """
    import ctypes
    import ctypes.util
    import gc

    gc.collect()
    cleanup = getattr(PETSc, "garbage_cleanup", None)
    if cleanup is not None:
        cleanup()
    try:
        ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


def _mpi_max():
    from mpi4py import MPI

    return MPI.MAX

