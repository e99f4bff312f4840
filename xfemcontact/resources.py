"""The memory a case needs, estimated from its mesh before the mesh is built, and the
refusal of a case that cannot fit.

    est = estimate("QUAD8", 1_000_000, nprocs=1)    # 1000 x 1000 QUAD8
    est.peak_mb                                      # per process, MB
    check_cells("QUAD8", 1_000_000, nprocs=1, where) # CaseError (exit 2) if it cannot fit

The estimate follows the data: cells -> nodes -> dofs (two per node) -> nonzeros of
the upper triangle of the matrix -> MUMPS factor entries (nested-dissection
growth, about ``n log^1.5 n`` with PORD, the ordering Debian's MUMPS uses) -> peak
resident memory of a process, each step with a coefficient fitted to the runs of
``bench/run_series.py`` (SSNV509 geometry, N = 160 .. 1000; see README,
*Performance*; in 3-D the oedometer on N x N x N boxes, HEXA20 N = 16 .. 32 and
TETRA10 N = 16 .. 24, ``make bench-3d``; see README, *3-D*).  It is meant to refuse
what cannot fit before anything large is allocated, not to be exact: it is within
about 10 % of the measured peaks of those runs, and the limit it is compared with
keeps a margin.

The limit is the memory this machine can give the run: the smallest of
``MemAvailable`` (/proc/meminfo), what the cgroup of the process still allows
(memory.max - memory.current, cgroup v2, or v1's limit), and the address-space
limit of a process (``ulimit -v``, compared with the estimated virtual size of a
process, which is larger than its resident size).  ``-xfc_memory_limit MB``
replaces it (``0``: no check).

Where it is called: :func:`xfemcontact.preflight.check_case` before a generated rectangle is built (from
its spec alone: a 10000 x 10000 rectangle is refused before a byte of it exists),
:func:`check_cells` in :func:`xfemcontact.mesh.plex.load` for every mesh before the
DMPlex is built, and in :func:`xfemcontact.mesh.refine.refine_uniform` before a
mesh read from a file is refined.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

from xfemcontact.errors import CaseError

if TYPE_CHECKING:
    from xfemcontact.errors import XfcError

#: nodes per cell of large meshes (N x N rectangles: QUAD8 3 N^2 + 4 N + 1 nodes for
#: N^2 cells, TRIA6 4 N^2 + 4 N + 1 for 2 N^2; N^3 boxes: HEXA20 about 4 N^3 nodes for
#: N^3 cells, TETRA10 8 N^3 for 6 N^3)
NODES_PER_CELL = {"QUAD8": 3.0, "TRIA6": 2.0, "HEXA20": 4.0, "TETRA10": 1.33}
#: the 3-D cell types (coefficients of their own below)
CELLS_3D = ("HEXA20", "TETRA10")
#: displacement dofs per node
DOFS_PER_NODE = {"QUAD8": 2, "TRIA6": 2, "HEXA20": 3, "TETRA10": 3}
#: nonzeros of the matrix's upper triangle per dof (2-D: measured at N = 320, bench;
#: 3-D: measured on N^3 boxes, HEXA20 N = 16, TETRA10 N = 12)
NNZ_PER_DOF = {"QUAD8": 13.1, "TRIA6": 12.2, "HEXA20": 78.4, "TETRA10": 39.2}
#: MUMPS factor entries (INFOG(29)) at a reference size and their growth with the dofs
#: (fitted to N = 160 .. 640: ``F = F_ref (n / n_ref) ** FACTOR_EXPONENT``, about n log^1.5 n
#: in 2-D; about n^(4/3) in 3-D: HEXA20 boxes N = 16 .. 32 give 1.35 (N = 32 predicted from
#: N = 16 within 1 %), TETRA10 boxes N = 16 .. 24 1.45 (least squares 1.53, N = 20 -> 24
#: 1.40), referred to N = 24)
FACTOR_REFERENCE = {"QUAD8": (2469238, 412824463), "TRIA6": (3288532, 471584508),
                    "HEXA20": (56355, 64961777), "TETRA10": (352947, 723505475)}
FACTOR_EXPONENT = {"QUAD8": 1.115, "TRIA6": 1.11, "HEXA20": 1.35, "TETRA10": 1.45}
#: peak resident MB of one process: BASE + PER_DOF x dofs + PER_ENTRY x factor entries
#: (the interpreter and libraries; the matrix, mesh, dof layout and vectors; MUMPS'
#: factors, 8 bytes an entry, with its work space and copy of the matrix), fitted to
#: the bench's peaks at N = 320 and 640 (within 6 %; 8 % low at N = 160)
BASE_MB = 100.0
PER_DOF_MB = 300e-6
PER_ENTRY_MB = 12.6e-6
#: the same in 3-D (HEXA20, TETRA10): MUMPS needs less beside its factors per entry
#: (measured 10.0 - 10.8 x 1e-6 MB at HEXA20 N = 20 .. 32 and TETRA10 N = 20, 24)
PER_ENTRY_MB_3D = 10.3e-6
#: on P processes the distributed part per process is (1 / P) x this imbalance
#: (measured 1.18 - 1.29 on 2 processes at N = 320 .. 1000), plus the input mesh
#: that rank 0 holds alone while it is distributed
IMBALANCE = 1.2
#: the same in 3-D: MUMPS' factors grow by a quarter on 2 processes, and the
#: larger process holds more (measured 1.34 - 1.41 at HEXA20 N = 24, 32 and TETRA10
#: N = 20, 24; 1.55 - 1.6 at N = 16, 20, where the memory is smaller)
IMBALANCE_3D = 1.4
#: the virtual size of a process exceeds its resident peak by about this (MUMPS'
#: relaxed work space, shared libraries)
VIRTUAL_EXTRA_MB = 700.0
#: share of the available memory a run may plan to use
MARGIN = 0.95

#: the estimate and limit of the last check (results.json "resources")
LAST: dict[str, Any] = {}


@dataclass
class Estimate:
    """What a mesh needs (see the module documentation): sizes, and memory in MB."""

    cell_type: str
    cells: int
    nodes: int
    dofs: int
    matrix_nonzeros: int       # upper triangle
    factor_entries: int
    processes: int
    peak_mb: float             # largest process (rank 0)
    total_mb: float            # all processes

    def as_dict(self) -> dict[str, Any]:
        return {k: (round(v, 1) if isinstance(v, float) else v) for k, v in asdict(self).items()}


def estimate(cell_type: str, cells: int, nprocs: int = 1, nodes: int | None = None) -> Estimate:
    """The :class:`Estimate` for ``cells`` cells of ``cell_type`` on ``nprocs`` processes
    (``nodes`` if known, else from the cell count)."""
    nodes = int(nodes if nodes is not None else NODES_PER_CELL[cell_type] * cells)
    dofs = DOFS_PER_NODE[cell_type] * nodes
    nnz = int(NNZ_PER_DOF[cell_type] * dofs)
    n_ref, f_ref = FACTOR_REFERENCE[cell_type]
    factor = int(f_ref * (dofs / n_ref) ** FACTOR_EXPONENT[cell_type])
    three_d = cell_type in CELLS_3D
    shared = PER_DOF_MB * dofs + (PER_ENTRY_MB_3D if three_d else PER_ENTRY_MB) * factor
    mesh_mb = 60e-6 * cells                       # the input mesh, rank 0 only, while it is distributed
    if nprocs <= 1:
        peak = BASE_MB + shared
        total = peak
    else:
        per = BASE_MB + (IMBALANCE_3D if three_d else IMBALANCE) * shared / nprocs
        peak = per + mesh_mb
        total = per * nprocs + mesh_mb
    return Estimate(cell_type, int(cells), nodes, dofs, nnz, factor, int(nprocs), peak, total)


# -- what the machine can give -------------------------------------------------------------

def _read(path: str) -> str | None:
    try:
        with open(path) as f:
            return f.read().strip()
    except OSError:
        return None


def _meminfo_mb(key: str = "MemAvailable") -> float | None:
    text = _read("/proc/meminfo") or ""
    for line in text.splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) / 1024.0
    return None


def _cgroup_mb() -> float | None:
    """What the cgroup of this process still allows, MB (None without a limit)."""
    rel = None
    for line in (_read("/proc/self/cgroup") or "").splitlines():
        parts = line.split(":", 2)
        if len(parts) == 3 and (parts[0] == "0" or "memory" in parts[1].split(",")):
            rel = parts[2]
            if parts[0] == "0":
                break
    candidates: list[float] = []
    if rel is not None:
        for base in ("/sys/fs/cgroup" + rel, "/sys/fs/cgroup"):
            limit, used = _read(base + "/memory.max"), _read(base + "/memory.current")
            if limit and limit != "max" and used:
                candidates.append((int(limit) - int(used)) / 2**20)
                break
        for base in ("/sys/fs/cgroup/memory" + rel, "/sys/fs/cgroup/memory"):
            limit, used = _read(base + "/memory.limit_in_bytes"), _read(base + "/memory.usage_in_bytes")
            if limit and used and int(limit) < 2**60:
                candidates.append((int(limit) - int(used)) / 2**20)
                break
    return min(candidates) if candidates else None


def _address_space_mb() -> float | None:
    """``ulimit -v`` of this process, MB (None when unlimited)."""
    import resource

    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    return None if soft == resource.RLIM_INFINITY else soft / 2**20


def limits(option: float | None = None) -> tuple[float | None, float | None, str | None]:
    """``(limit of all processes MB, limit of one process's virtual size MB, what set it)``:
    ``option`` (MB, from -xfc_memory_limit) if given, else what the machine can give."""
    if option is not None:
        return option, None, "-xfc_memory_limit"
    found: list[tuple[float, str]] = []
    avail = _meminfo_mb()
    if avail is not None:
        found.append((avail, "MemAvailable"))
    cg = _cgroup_mb()
    if cg is not None:
        found.append((cg, "cgroup limit"))
    total, why = min(found) if found else (None, None)
    return total, _address_space_mb(), why


def _option_mb() -> float | None:
    """-xfc_memory_limit MB: None if not given; 0 or less: no check (returns -1)."""
    from xfemcontact import options

    value = options.get("memory_limit")
    if value is None:
        return None
    return value if value > 0 else -1.0


# -- the checks ----------------------------------------------------------------------------

def _gb(mb: float) -> str:
    return f"{mb / 1024:.1f} GB" if mb >= 1024 else f"{mb:.0f} MB"


def check_cells(cell_type: str, cells: int, nprocs: int, where: str, nodes: int | None = None,
                error: type[XfcError] = CaseError) -> Estimate:
    """Raise ``error`` (one line, exit code 2) when ``cells`` cells cannot fit; returns the
    :class:`Estimate`.  ``where``: the start of the message (file and key)."""
    est = estimate(cell_type, cells, nprocs, nodes)
    option = _option_mb()
    LAST.clear()
    LAST.update(est.as_dict())
    if option is not None and option < 0:          # -xfc_memory_limit 0: no check
        LAST["limit_mb"] = None
        return est
    total, per_process, why = limits(option)
    LAST["limit_mb"] = round(total, 1) if total is not None else None
    too_big = None
    if total is not None and est.total_mb > MARGIN * total:
        too_big = (f"{_gb(est.total_mb)} on {nprocs} process{'es' if nprocs > 1 else ''}, "
                   f"{_gb(total)} available ({why}), of which a run may use {MARGIN:.0%}")
    elif per_process is not None and est.peak_mb + VIRTUAL_EXTRA_MB > per_process:
        too_big = (f"{_gb(est.peak_mb + VIRTUAL_EXTRA_MB)} of address space per process, "
                   f"ulimit -v allows {_gb(per_process)}")
    if too_big:
        raise error(f"{where}: {cells} {cell_type} cells ({est.dofs:.3g} dofs) need about {too_big}: "
                    f"use a coarser mesh or a machine with more memory (-xfc_memory_limit MB sets the "
                    f"limit, 0 switches this check off)", collective=True)
    return est


def current_nprocs() -> int:
    """Number of processes of the run (PETSc's world)."""
    from xfemcontact._petsc import PETSc

    return PETSc.COMM_WORLD.size


def summary() -> dict[str, Any] | None:
    """The last check's estimate and limit (results.json ``resources``), or None."""
    if not LAST:
        return None
    out = dict(LAST)
    out["estimate_mb"] = out.pop("peak_mb")
    return out

