"""Import petsc4py from Debian's PETSc and initialise it exactly once.

Debian installs petsc4py under ``$PETSC_DIR/lib/python3/dist-packages`` and adds
that folder to ``sys.path`` through a ``.pth`` file that reads ``PETSC_DIR`` when
Python starts.  A user who did not export ``PETSC_DIR`` would get
``ModuleNotFoundError: petsc4py``; we add the folder ourselves so that they never
have to know.

Open MPI picks its point-to-point layer (PML) at ``MPI_Init`` by trying each one;
trying UCX costs 0.2 s per process and, on one machine, ends with the same ``ob1``
shared-memory layer.  When every process runs on this machine (no launcher, or
Open MPI reports as many local ranks as ranks) and the user has not chosen a
PML (``OMPI_MCA_pml``), we choose ``ob1`` before MPI starts.

Every module that needs PETSc does ``from xfemcontact._petsc import PETSc``.
PETSc reads some options only when it starts (``-log_view``, ``-help``), so the
command line stores the options it did not consume in
``xfemcontact.PETSC_ARGV`` before anything imports this module.
"""
from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING, Any, MutableMapping, Sequence

if TYPE_CHECKING:
    from types import ModuleType

DEBIAN_PETSC_DIR = "/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real"


def _import_petsc4py() -> ModuleType:
    try:
        import petsc4py
    except ImportError:
        petsc_dir = os.environ.get("PETSC_DIR") or DEBIAN_PETSC_DIR
        os.environ["PETSC_DIR"] = petsc_dir
        sys.path.append(os.path.join(petsc_dir, "lib", "python3", "dist-packages"))
        import petsc4py
    return petsc4py


def _single_host_pml(env: MutableMapping[str, str] = os.environ) -> None:
    """``OMPI_MCA_pml=ob1`` when all processes are local and no PML was chosen."""
    if "OMPI_MCA_pml" in env:
        return
    size, local = env.get("OMPI_COMM_WORLD_SIZE"), env.get("OMPI_COMM_WORLD_LOCAL_SIZE")
    launched = size is not None or any(k in env for k in ("PMIX_RANK", "PMI_RANK", "SLURM_PROCID"))
    if not launched or (size is not None and size == local):
        env["OMPI_MCA_pml"] = "ob1"


def init(argv: Sequence[str] | None = None) -> Any:
    """Initialise PETSc with ``argv`` (a list of PETSc options); idempotent.  Returns the
    ``petsc4py.PETSc`` module (Any: petsc4py has no type information)."""
    if "petsc4py.PETSc" not in sys.modules:
        _single_host_pml()
    petsc4py = _import_petsc4py()
    if "petsc4py.PETSc" not in sys.modules:
        petsc4py.init([sys.argv[0] if sys.argv else "xfemcontact"] + list(argv or []))
    from petsc4py import PETSc as _PETSc
    return _PETSc


def _pending_argv() -> list[str]:
    pkg = sys.modules.get("xfemcontact")
    return list(getattr(pkg, "PETSC_ARGV", []))


PETSc = init(_pending_argv())
