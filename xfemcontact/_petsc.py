"""Import petsc4py from Debian's PETSc and initialise it exactly once.

Debian installs petsc4py under ``$PETSC_DIR/lib/python3/dist-packages`` and adds
that folder to ``sys.path`` through a ``.pth`` file that reads ``PETSC_DIR`` when
Python starts.  A user who did not export ``PETSC_DIR`` would get
``ModuleNotFoundError: petsc4py``; we add the folder ourselves so that they never
have to know.

Every module that needs PETSc does ``from xfemcontact._petsc import PETSc``.
PETSc reads some options only when it starts (``-log_view``, ``-help``), so the
command line stores the options it did not consume in
``xfemcontact.PETSC_ARGV`` before anything imports this module.
"""
import os
import sys

DEBIAN_PETSC_DIR = "/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real"


def _import_petsc4py():
    try:
        import petsc4py
    except ImportError:
        petsc_dir = os.environ.get("PETSC_DIR") or DEBIAN_PETSC_DIR
        os.environ["PETSC_DIR"] = petsc_dir
        sys.path.append(os.path.join(petsc_dir, "lib", "python3", "dist-packages"))
        import petsc4py
    return petsc4py


def init(argv=None):
    """Initialise PETSc with ``argv`` (a list of PETSc options); idempotent."""
    petsc4py = _import_petsc4py()
    if "petsc4py.PETSc" not in sys.modules:
        petsc4py.init([sys.argv[0] if sys.argv else "xfemcontact"] + list(argv or []))
    from petsc4py import PETSc as _PETSc
    return _PETSc


def _pending_argv():
    pkg = sys.modules.get("xfemcontact")
    return list(getattr(pkg, "PETSC_ARGV", []))


PETSc = init(_pending_argv())
