"""Command line: ``xfemcontact run CASE.toml [-o OUTDIR] [--overwrite] [PETSc options...]``.

Every option we do not know goes to PETSc (``-snes_monitor``, ``-ksp_view``,
``-log_view``, ``-pc_factor_mat_solver_type``, ``-mat_mumps_icntl_24 1`` ...).
The case file is the first argument ending in ``.toml``.  Also runs as
``python -m xfemcontact`` and under ``mpirun -n P``.

Errors are one line on stderr, ``error: ...`` (see :mod:`xfemcontact.errors`
and docs/errors.md): a collective error is printed by rank 0 and every process
returns its exit code; any other error is printed by the process that raised it
and aborts the run under MPI.  SIGINT and SIGTERM stop the run cleanly
(:func:`xfemcontact.output.folder.handle_signals`): one line
``interrupted (SIGTERM): previous results in X kept`` / ``...: no results
written``, exit code 130 / 143.
"""
import os
import sys

import xfemcontact

USAGE = """usage: xfemcontact run CASE.toml [-o OUTDIR] [--overwrite] [PETSc options...]

  CASE.toml        the case file (TOML, see README.md)
  -o, --output DIR result folder (default: results/<case name>)
  --overwrite      replace an existing result folder
  PETSc options    anything else, e.g. -snes_monitor -ksp_view -log_view
                   -pc_factor_mat_solver_type mumps -mat_mumps_icntl_24 1
exit codes: 0 solved and all tests OK, 1 a test NOOK, 2 bad input, 3 no convergence,
            130/143 interrupted (SIGINT/SIGTERM; previous results kept)
"""


def split_args(argv):
    """Our arguments and the PETSc ones: ``(case, outdir, overwrite, help, petsc_args)``."""
    case = outdir = None
    overwrite = want_help = False
    petsc = []
    it = iter(argv)
    for tok in it:
        if tok in ("-o", "--output"):
            outdir = next(it, None)
        elif tok.startswith("--output="):
            outdir = tok.split("=", 1)[1]
        elif tok == "--overwrite":
            overwrite = True
        elif tok in ("-h", "--help"):
            want_help = True
        elif case is None and not tok.startswith("-") and tok.endswith(".toml"):
            case = tok
        else:
            petsc.append(tok)
    return case, outdir, overwrite, want_help, petsc


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(USAGE, end="")
        return 0
    if argv[0] != "run":
        print(USAGE, end="", file=sys.stderr)
        return 2
    case, outdir, overwrite, want_help, petsc = split_args(argv[1:])
    if want_help or case is None:
        print(USAGE, end="")
        return 0 if want_help else 2
    xfemcontact.PETSC_ARGV[:] = petsc
    from xfemcontact.errors import Interrupted, XfcError
    from xfemcontact.output.folder import handle_signals, restore_signals

    previous = handle_signals()       # SIGINT/SIGTERM -> Interrupted: a clean stop
    comm = None
    try:
        from xfemcontact._petsc import PETSc

        comm = PETSc.COMM_WORLD
        from xfemcontact.run import run

        return run(case, outdir, overwrite)
    except Interrupted as exc:
        # every process is signalled by mpirun; rank 0 knows what became of the results
        if comm is None or comm.rank == 0:
            print(str(exc), file=sys.stderr, flush=True)
        return exc.exit_code
    except XfcError as err:
        if err.collective:
            # raised identically on every process: report once, everybody leaves
            if comm is None or comm.rank == 0:
                print(f"error: {err}", file=sys.stderr, flush=True)
            return err.exit_code
        print(f"error: {err}", file=sys.stderr, flush=True)
        return _finish(comm, err.exit_code)
    except BaseException:
        if comm is None or comm.size == 1:
            raise
        import traceback

        traceback.print_exc()
        return _finish(comm, 1)
    finally:
        restore_signals(previous)


def console(argv=None):
    """The ``xfemcontact`` command (and ``python -m xfemcontact``): :func:`main`, then
    leave at once.  Everything is written by then; tearing the interpreter down
    (modules, arrays of a large model) would cost another 0.1 - 0.2 s."""
    code = main(argv)
    _leave(code if isinstance(code, int) else 1)


def _leave(code):
    """Finalize PETSc (which writes ``-log_view``) and MPI, flush, and exit with ``code``."""
    petsc = sys.modules.get("petsc4py.PETSc")
    if petsc is not None:
        getattr(petsc, "_finalize", lambda: None)()
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized() and not mpi.Is_finalized():
        mpi.Finalize()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def _finish(comm, code):
    """Leave with ``code``; under MPI a failure on one process must stop all of them."""
    if comm is not None and comm.size > 1:
        sys.stderr.flush()
        comm.tompi4py().Abort(code)
    return code
