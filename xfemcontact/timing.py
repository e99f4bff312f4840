"""Phase timing: one PETSc log event per phase, and wall times for results.json.

``with phase("assembly"):`` opens the PETSc log event ``XFC:assembly`` (visible in
``-log_view``) and adds the elapsed wall time to :data:`TIMINGS` (seconds).
"""
import time
from contextlib import contextmanager

from xfemcontact._petsc import PETSc

TIMINGS = {}
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
        ev.end()


def reset():
    TIMINGS.clear()


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
    """Peak resident memory of every process, MB."""
    import resource

    return comm.tompi4py().allgather(round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1))


def release_heap():
    """Give the memory freed by the set-up's temporaries back to the system (glibc
    keeps freed heap pages): the factorisation that follows then raises the peak
    from a lower floor.  A no-op where ``malloc_trim`` does not exist."""
    import ctypes
    import ctypes.util
    import gc

    gc.collect()
    try:
        ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


def _mpi_max():
    from mpi4py import MPI

    return MPI.MAX
