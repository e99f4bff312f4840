"""xfemcontact: frictional contact on level-set interfaces with quadratic X-FEM, on PETSc.

The data flow follows the sub-packages: ``case`` (TOML case files, formulas) ->
``mesh`` (meshio input, DMPlex) -> ``xfem`` (level set, cut geometry, enrichment)
-> ``dofs`` (PetscSection layout, multiplier space) -> ``assembly`` (bulk and
interface terms) -> ``contact`` (pointwise law) and ``solver`` (SNES loops) ->
``post`` (fields, interface values, tests) -> ``output`` (files, report).
"""
from __future__ import annotations

import os as _os

# One BLAS thread per process unless the user says otherwise: parallelism comes
# from MPI, and threaded OpenBLAS is slow on the many tiny products we batch.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

__version__ = "0.1.0"

#: PETSc options handed to PetscInitialize (set by the command line before the
#: first import of petsc4py).
PETSC_ARGV: list[str] = []
