"""xfemcontact: PETSc-based frictional contact on level-set interfaces with quadratic X-FEM."""
from setuptools import find_packages, setup

setup(
    name="xfemcontact",
    version="0.1.0",
    description="Parallel X-FEM frictional contact solver (P2 Heaviside / P1 multipliers) on PETSc",
    long_description=open("README.md", encoding="utf-8").read(),
    long_description_content_type="text/markdown",
    license="GPL-3.0-or-later",
    python_requires=">=3.11",
    packages=find_packages(include=["xfemcontact", "xfemcontact.*"]),
    # petsc4py, mpi4py, numpy, scipy, meshio, h5py and matplotlib come from Debian
    # (see the Makefile); pip must not try to build them.
    install_requires=[],
    entry_points={"console_scripts": ["xfemcontact = xfemcontact.cli:console"]},
)
