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
