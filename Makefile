# xfemcontact -- set-up, run, test, bench.
#
# `make run` and `make test` install whatever is missing (Debian packages, the
# virtual environment, the package itself) and are quick and quiet when all is
# already there.

SHELL := /bin/bash
.DEFAULT_GOAL := help

# PETSc from Debian: petsc4py's path hook needs PETSC_DIR before Python starts.
export PETSC_DIR ?= /usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real
# Open MPI refuses root without these; CI machines run as root.
export OMPI_ALLOW_RUN_AS_ROOT := 1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM := 1
export OMPI_MCA_rmaps_base_oversubscribe := 1
# One BLAS thread per MPI process: MUMPS parallelism comes from MPI.
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1

# libopenblas0-pthread: without it PETSc's BLAS dependency is met by the
# reference BLAS, and the MUMPS factorisations run several times slower.
DEBS := python3-petsc4py-real python3-mpi4py openmpi-bin python3-meshio \
        python3-h5py python3-numpy python3-scipy python3-matplotlib \
        python3-pytest python3-venv libopenblas0-pthread
PYPI := hypothesis pymetis
# `make lint` only; pinned: a newer mypy may find new things to say about the same code
LINT_PYPI := mypy==2.4.1 pyflakes==4.1.0

VENV := .venv
PY := $(VENV)/bin/python
STAMP_DEBS := $(VENV)/.debs-installed
STAMP_PKG := $(VENV)/.package-installed
STAMP_LINT := $(VENV)/.lint-installed
CASE ?= cases/ssnv509a.toml
OUT ?= out

.PHONY: help setup run test test-fast lint bench bench-quick bench-large bench-3d clean bytecode

help:
	@echo "make run     solve $(CASE) and print its test table (output in $(OUT)/)"
	@echo "make test    run the whole test suite (MPI tests included)"
	@echo "make lint    pyflakes (package, tests, bench, cases) and mypy (package, mypy.ini)"
	@echo "make bench   run the benchmark series (bench/): 2-D N = 20 ... 320 and QUAD8 640, 1000, then 3-D (about 45 min)"
	@echo "make bench-quick   only N = 20 ... 320 (QUAD8, TRIA6, 1 and 2 processes; about 5 min)"
	@echo "make bench-3d      only 3-D: HEXA20, TETRA10 N x N x N boxes, N = 8 ... 24, 1 and 2 processes (about 15 min, 7.5 GB)"
	@echo "make setup   install Debian packages, .venv and the package only"

setup: $(STAMP_PKG)

$(STAMP_DEBS):
	@missing=""; for p in $(DEBS); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  export DEBIAN_FRONTEND=noninteractive; \
	  apt-get update -qq && apt-get install -y -qq --no-install-recommends $$missing >/dev/null; \
	fi
	@test -x $(PY) || /usr/bin/python3 -m venv --system-site-packages $(VENV)
	@touch $@

$(STAMP_PKG): $(STAMP_DEBS) setup.py
	@$(PY) -m pip install -q --disable-pip-version-check $(PYPI)
	@$(PY) -m pip install -q --disable-pip-version-check --no-build-isolation --no-deps -e .
	@touch $@

# Python compiles the package at every start when PYTHONDONTWRITEBYTECODE is set
# (0.1 s); compileall writes the .pyc files anyway, and only the stale ones.
bytecode: $(STAMP_PKG)
	@$(PY) -m compileall -q xfemcontact >/dev/null

run: bytecode
	$(VENV)/bin/xfemcontact run $(CASE) -o $(OUT) --overwrite

test: bytecode
	$(PY) -m pytest -q tests

test-fast: bytecode
	$(PY) -m pytest -q -m "not slow" tests

$(STAMP_LINT): $(STAMP_PKG)
	@$(PY) -m pip install -q --disable-pip-version-check $(LINT_PYPI)
	@touch $@

lint: $(STAMP_LINT)
	$(PY) -m pyflakes xfemcontact tests bench cases
	$(PY) -m mypy

# N = 20 ... 320, QUAD8 and TRIA6, 1 and 2 processes -> bench/results/series.{md,json,png};
# QUAD8 640 and 1000 (2.5 and 6 million dofs), 1 and 2 processes -> bench/results/large.*;
# then the 3-D series (bench-3d)
bench: bench-quick bench-large bench-3d

bench-quick: bytecode
	$(PY) bench/run_series.py

bench-large: bytecode
	$(PY) bench/run_series.py --cells QUAD8 --sizes 640 1000 --procs 1 2 --name large

# the oedometer of cases/box_hexa20.toml on N x N x N HEXA20 and TETRA10 boxes, 1 and 2 processes:
# N = 8 ... 20 three times each (medians) -> bench/results/series3d.*; N = 24 once
# (up to 341 000 dofs, 7.5 GB) -> bench/results/series3d_large.*
bench-3d: bytecode
	$(PY) bench/run_series.py --cells HEXA20 TETRA10 --sizes 8 12 16 20 --procs 1 2 --repeat 3 --name series3d
	$(PY) bench/run_series.py --cells HEXA20 TETRA10 --sizes 24 --procs 1 2 --name series3d_large

clean:
	rm -rf $(VENV) out build *.egg-info .pytest_cache .mypy_cache
