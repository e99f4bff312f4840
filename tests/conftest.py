"""Shared helpers: write case files, run the command line (also under mpirun)."""
import json
import os
import pathlib
import subprocess
import sys
import textwrap

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
CASES = ROOT / "cases"
MESHES = CASES / "meshes"
# code_aster's own SSNV509 meshes, next to the checkout (../shared/meshes), wherever it lives
SHARED_MESHES = ROOT.parent / "shared" / "meshes"

ENV = dict(os.environ,
           PETSC_DIR=os.environ.get("PETSC_DIR", "/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real"),
           OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")


def write_case(directory, text, name="case.toml"):
    """Write a TOML case (dedented) into ``directory``; returns its path."""
    path = pathlib.Path(directory) / name
    path.write_text(textwrap.dedent(text))
    return path


def run_cli(args, np=None, timeout=600, cwd=None):
    """Run ``python -m xfemcontact`` (under ``mpirun -n np`` if np); returns CompletedProcess."""
    cmd = [sys.executable, "-m", "xfemcontact"] + [str(a) for a in args]
    if np:
        cmd = ["mpirun", "-n", str(np), "--oversubscribe"] + cmd
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=ENV,
                          cwd=cwd or ROOT)


def run_python(script, np=None, timeout=600, args=()):
    """Run a Python script file (under mpirun if np)."""
    cmd = [sys.executable, str(script)] + [str(a) for a in args]
    if np:
        cmd = ["mpirun", "-n", str(np), "--oversubscribe"] + cmd
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=ENV, cwd=ROOT)


def results(outdir):
    return json.loads((pathlib.Path(outdir) / "results.json").read_text())


@pytest.fixture
def case_dir(tmp_path):
    return tmp_path
