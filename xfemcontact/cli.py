"""Command line: ``xfemcontact run CASE.toml [-o OUTDIR] [--overwrite] [--restart] [-q] [PETSc options...]``.

Every option we do not know goes to PETSc (``-snes_monitor``, ``-ksp_view``,
``-log_view``, ``-pc_factor_mat_solver_type``, ``-mat_mumps_icntl_24 1`` ...).
The case file is the first argument ending in ``.toml``.  Also runs as
``python -m xfemcontact`` and under ``mpirun -n P``.

Errors are one line on stderr, ``error: ...`` (see :mod:`xfemcontact.errors`
and README.md): a collective error is printed by rank 0 and every process
returns its exit code; any other error is printed by the process that raised it
and aborts the run under MPI.  SIGINT, SIGTERM and SIGHUP stop the run cleanly
(:func:`xfemcontact.output.folder.handle_signals`): one line
``interrupted (SIGTERM): previous results in X kept`` / ``...: no results
written``, exit code 130 / 143 / 129.  Under MPI a signal that reaches some
processes only (``kill`` of one rank) ends the whole job: the processes that
received it wait :data:`SIGNAL_AGREEMENT` seconds for the others (mpirun forwards
its signals to all), then abort the run (``MPI_Abort``).  A standard output
closed early (``xfemcontact run ... | head -1``) does not stop the run.
"""
from __future__ import annotations

import os
import sys
import time
from typing import TYPE_CHECKING, NoReturn, Sequence

import xfemcontact

if TYPE_CHECKING:
    from mpi4py import MPI
    from petsc4py import PETSc

#: seconds the processes that received a signal wait for the others before aborting
SIGNAL_AGREEMENT = 2.0

USAGE = """usage: xfemcontact run CASE.toml [-o OUTDIR] [--overwrite] [--restart] [-q] [PETSc options...]

  CASE.toml        the case file (TOML, see README.md)
  -o, --output DIR result folder (default: results/<case name>)
  --overwrite      replace an existing result folder (only one xfemcontact wrote)
  --restart        resume a case with [instants] after its last checkpointed step
                   (OUTDIR.checkpoints; same number of processes)
  -q, --quiet      no progress line per load step
  PETSc options    anything else, e.g. -snes_monitor -ksp_view -log_view
                   -pc_factor_mat_solver_type mumps -mat_mumps_icntl_24 1
                   (-help lists them all)
exit codes: 0 solved and all tests OK, 1 a test NOOK, 2 bad input, 3 no convergence,
            130/143/129 interrupted (SIGINT/SIGTERM/SIGHUP; previous results kept)
"""


def usage() -> str:
    """The usage text, with our own options (:mod:`xfemcontact.options`)."""
    from xfemcontact import options

    return USAGE + "\n".join(options.help_lines()) + "\n"


def split_args(argv: Sequence[str], flags: dict[str, bool] | None = None
               ) -> tuple[str | None, str | None, bool, bool, list[str]]:
    """Our arguments and the PETSc ones: ``(case, outdir, overwrite, help, petsc_args)``;
    ``flags`` (a dict), if given, gets ``restart`` and ``quiet``."""
    case: str | None = None
    outdir: str | None = None
    overwrite = want_help = False
    petsc: list[str] = []
    flags = {} if flags is None else flags
    flags.setdefault("restart", False)
    flags.setdefault("quiet", False)
    it = iter(argv)
    for tok in it:
        if tok in ("-o", "--output"):
            outdir = next(it, None)
        elif tok.startswith("--output="):
            outdir = tok.split("=", 1)[1]
        elif tok == "--overwrite":
            overwrite = True
        elif tok == "--restart":
            flags["restart"] = True
        elif tok in ("-q", "--quiet"):
            flags["quiet"] = True
        elif tok in ("-h", "--help"):
            want_help = True
        elif case is None and not tok.startswith("-") and tok.endswith(".toml"):
            case = tok
        else:
            petsc.append(tok)
    return case, outdir, overwrite, want_help, petsc


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line ``argv`` (default: ``sys.argv[1:]``); returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(usage(), end="")
        return 0
    if argv[0] != "run":
        print(usage(), end="", file=sys.stderr)
        return 2
    flags: dict[str, bool] = {}
    case, outdir, overwrite, want_help, petsc = split_args(argv[1:], flags)
    if want_help or case is None:
        print(usage(), end="")
        return 0 if want_help else 2
    xfemcontact.PETSC_ARGV[:] = petsc
    from xfemcontact.errors import Interrupted, XfcError
    from xfemcontact.output.folder import handle_signals, restore_signals

    _quiet_numerics()
    previous = handle_signals()       # SIGINT/SIGTERM/SIGHUP -> Interrupted: a clean stop
    comm: PETSc.Comm | None = None
    agreement: MPI.Comm | None = None
    try:
        from xfemcontact._petsc import PETSc

        handle_signals(reset=False)   # again: PETSc installs its own when it starts
        comm = PETSc.COMM_WORLD
        if comm.size > 1:
            agreement = comm.tompi4py().Dup()
        from xfemcontact.run import run

        return run(case, outdir, overwrite, restart=flags["restart"], quiet=flags["quiet"])
    except Interrupted as exc:
        # mpirun forwards a signal to every process, and rank 0 knows what became of the
        # results; a signal to some processes only must end the whole job
        if comm is None or comm.rank == 0:
            _say(str(exc))
        alone = agreement is not None and not _all_arrive(agreement, SIGNAL_AGREEMENT)
        if alone and comm is not None and comm.rank != 0:       # alone: several processes
            _say(f"interrupted ({exc.name}) on process {comm.rank} of {comm.size}: "
                 f"stopping every process")
        if alone:
            return _finish(comm, exc.exit_code)
        return exc.exit_code
    except XfcError as err:
        if err.collective:
            # raised identically on every process: report once, everybody leaves
            if comm is None or comm.rank == 0:
                _say(f"error: {err}")
            return err.exit_code
        _say(f"error: {err}")
        return _finish(comm, err.exit_code)
    except BrokenPipeError:                  # our standard output was closed: nothing to say
        return _finish(comm, 1)
    except BaseException:
        if comm is None or comm.size == 1:
            raise
        import traceback

        traceback.print_exc()
        return _finish(comm, 1)
    finally:
        restore_signals(previous)


def console(argv: Sequence[str] | None = None) -> NoReturn:
    """The ``xfemcontact`` command (and ``python -m xfemcontact``): :func:`main`, then
    leave at once.  Everything is written by then; tearing the interpreter down
    (modules, arrays of a large model) would cost another 0.1 - 0.2 s."""
    code = main(argv)
    _leave(code if isinstance(code, int) else 1)


def _leave(code: int) -> NoReturn:
    """Finalize PETSc (which writes ``-log_view``) and MPI, flush, and exit with ``code``."""
    petsc = sys.modules.get("petsc4py.PETSc")
    if petsc is not None:
        getattr(petsc, "_finalize", lambda: None)()
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized() and not mpi.Is_finalized():
        mpi.Finalize()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):     # closed by the reader (| head): nothing to do
            pass
    os._exit(code)


def _say(line: str) -> None:
    """One line on stderr, even when it is closed."""
    try:
        print(line, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass


def _quiet_numerics() -> None:
    """No NumPy warnings on stderr: every value that matters is checked for being finite
    and reported in one line (formulas, residuals, results)."""
    import warnings

    import numpy as np

    np.seterr(all="ignore")
    warnings.filterwarnings("ignore", category=RuntimeWarning)


def _all_arrive(comm: MPI.Comm, timeout: float) -> bool:
    """Whether every process of ``comm`` reaches this point within ``timeout`` seconds
    (a non-blocking barrier on a communicator of its own)."""
    request = comm.Ibarrier()
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if request.Test():
            return True
        time.sleep(0.01)
    return False


def _finish(comm: PETSc.Comm | None, code: int) -> int:
    """Leave with ``code``; under MPI a failure on one process must stop all of them."""
    if comm is not None and comm.size > 1:
        sys.stderr.flush()
        comm.tompi4py().Abort(code)
    return code
