"""Shared helpers: write case files, run the command line (also under mpirun)."""
import hashlib
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


class Runs:
    """Command-line runs done once per test session: several tests that only read the
    results of the same run (the same case file, text and options, the same number of
    processes) share one run instead of each starting it again.  The output folders are
    read-only for the tests (a test that writes into its output, or restarts it, runs its
    own)."""

    def __init__(self, root):
        self.root = pathlib.Path(root)
        self.done = {}

    def case(self, text, name="case.toml"):
        """``text`` written once as ``name`` in a folder of its own: the same text gives the
        same path, so that its runs are shared (mesh files by absolute path, or none)."""
        path = self.root / "cases" / hashlib.sha1(text.encode()).hexdigest()[:16] / name
        if not path.exists():
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
        return path

    def __call__(self, case, *options, np_=None):
        """``xfemcontact run case -o OUT *options`` (under ``mpirun -n np_`` if np_), once per
        session: the CompletedProcess and OUT."""
        case = pathlib.Path(case).resolve()
        key = (str(case), case.read_text(), tuple(str(o) for o in options), np_)
        if key not in self.done:
            out = self.root / "runs" / str(len(self.done)) / "out"
            out.parent.mkdir(parents=True)
            self.done[key] = (run_cli(["run", case, "-o", out, *options], np=np_), out)
        return self.done[key]


@pytest.fixture(scope="session")
def run_once(tmp_path_factory):
    """The session's :class:`Runs`."""
    return Runs(tmp_path_factory.mktemp("shared"))


@pytest.fixture
def case_dir(tmp_path):
    return tmp_path


def inclusion_case(directory, cell="QUAD8", n=20, radius=2.3, algo=None):
    """A floating inclusion of bench/inclusion_family.py (held by contact and friction alone)
    on n x n ``cell``, radius ``radius`` (m), multiplier space ``algo`` (None: the default),
    written into ``directory``; returns its path."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("inclusion_family", ROOT / "bench" / "inclusion_family.py")
    family = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(family)
    case = pathlib.Path(directory) / f"inclusion_{cell}_{n}_{radius}_{algo}.toml"
    case.write_text(family.variant(family.TEMPLATE.read_text(), cell, n, radius, algo))
    return case


def with_contact_keys(path, directory, **keys):
    """A copy of the case ``path`` in ``directory`` with ``[contact]`` keys set (values as
    TOML text, e.g. ``integration='"GAUSS"'``); mesh files stay where they were."""
    import re

    text = pathlib.Path(path).read_text()
    text = re.sub(r'(file\s*=\s*")(?!/)', lambda m: m.group(1) + str(pathlib.Path(path).parent) + "/", text)
    for key, value in keys.items():
        text = re.sub(rf"^{key}\s*=.*\n", "", text, flags=re.M)
        if "[contact]" in text:
            text = text.replace("[contact]\n", f"[contact]\n{key} = {value}\n", 1)
        else:
            text += f"\n[contact]\n{key} = {value}\n"
    out = pathlib.Path(directory) / pathlib.Path(path).name
    out.write_text(text)
    return out


def gauss(path, directory):
    """The case ``path`` with code_aster's Gauss-point contact (``integration = "GAUSS"``)."""
    return with_contact_keys(path, directory, integration='"GAUSS"')


@pytest.fixture
def null_pivot_detection():
    """MUMPS null-pivot detection (-mat_mumps_icntl_24 1) in the options database, for the
    models a test builds in its own process."""
    from xfemcontact._petsc import PETSc

    opts = PETSc.Options()
    opts.setValue("mat_mumps_icntl_24", "1")
    yield
    opts.delValue("mat_mumps_icntl_24")
