"""What a run will cost, estimated before anything large is allocated, and refused beyond the limit.

The thermal commands know their mesh from the grid lines alone (1-D, cheap:
:func:`imutherm.geometry.mesh.grid_shape`), so cells, unknowns, time steps and
saved fields are counted before any 3-D array exists; memory is that count
times a measured figure per unknown. A run whose estimate exceeds the limit
(``--max-memory``, default: the memory the machine has available now,
``MemAvailable`` of /proc/meminfo) is refused with the estimate and the limit
in the message.

This module is the base of the cost limits and imports nothing above it (``tests/test_layers.py``): the
costs that need a study's configuration (the time steps of ``run_scheme``'s arguments, the IMU side of the
end-to-end study) are in :mod:`imutherm.studies.cost`, the ``--max-memory`` option in
:mod:`imutherm.cli._options`.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass

from imutherm import InputError

#: peak resident memory per unknown of ``imutherm solve`` [bytes] (steady: assembly, AMG hierarchy,
#: field output). Measured by ``benchmarks/bench_memory.py`` on the reference unit: 2.3 kB at
#: 186 k and 214 k unknowns; rounded up with margin.
BYTES_PER_UNKNOWN_SOLVE = 3000
#: the same for ``imutherm geometry`` (mesh, STL/GLB/VTU export, picture) [bytes], measured ~0.5 kB
BYTES_PER_UNKNOWN_GEOMETRY = 1000
#: interpreter, numpy, scipy, scikit-fem, pyamg, meshio loaded [bytes] (measured 75 MiB)
BASE_BYTES = 100 * 2**20
#: a field kept for output (one float64 per node, plus its copy when written) [bytes per unknown]
BYTES_PER_SAVED_VALUE = 16
#: most transient time steps accepted: 1e5 steps of the ~0.2 s each a 2e5-unknown step takes here
#: are ~6 h; more is a typing error (e.g. ``--t-end 1e9 --dt 1e-3``) rather than a study
MAX_TIME_STEPS = 100_000
#: most fields kept for the PVD series (``--save-every``)
MAX_SAVED_FIELDS = 10_000
#: most mesh cells accepted whatever the memory: 2e7 cells are ~60 GB of solve
MAX_CELLS = 20_000_000


def available_memory_bytes() -> int:
    """Memory the machine can give a new process now [bytes]: ``MemAvailable`` of /proc/meminfo
    (elsewhere: physical pages x page size)."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover
        return 8 * 2**30


_UNITS = {"": 1, "b": 1, "k": 1e3, "kb": 1e3, "kib": 2**10, "m": 1e6, "mb": 1e6, "mib": 2**20,
          "g": 1e9, "gb": 1e9, "gib": 2**30, "t": 1e12, "tb": 1e12, "tib": 2**40}


def release_freed_memory() -> None:
    """Give the memory a process has freed back to the system: a garbage collection, then glibc's
    ``malloc_trim(0)`` where there is one (Linux). Freed arrays of a few MB stay in the heap otherwise and count in
    the process's resident memory (a study worker after its thermal case: 432 -> 191 MB, the reference unit's air
    scheme); elsewhere only the collection."""
    import ctypes
    import ctypes.util
    import gc

    gc.collect()
    name = ctypes.util.find_library("c")
    try:
        trim = ctypes.CDLL(name).malloc_trim if name else None
    except (OSError, AttributeError):   # not glibc (macOS, musl without it, Windows)
        trim = None
    if trim is not None:
        trim(0)


def parse_size(text: str) -> int:
    """A memory size like ``8G``, ``512MiB``, ``2.5e9`` [bytes]; ValueError if not one (for argparse)."""
    m = re.fullmatch(r"\s*([0-9.]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*", str(text))
    if not m or m.group(2).lower() not in _UNITS:
        raise ValueError(f"not a memory size: {text!r} (e.g. 8G, 512M, 2e9)")
    value = float(m.group(1)) * _UNITS[m.group(2).lower()]
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"not a memory size > 0: {text!r}")
    return int(value)


def fmt_bytes(n: float) -> str:
    """``n`` bytes as a short human figure (``1.2 GiB``)."""
    for unit, size in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("kiB", 2**10)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n:.0f} B"


def count_time_steps(t_end: float, dt: float, dt_max: float | None = None, growth: float = 1.2) -> int:
    """Number of transient steps [-] of :func:`imutherm.thermal.transient.time_steps` (within one), in O(1)."""
    if dt_max is None or dt_max <= dt or growth <= 1.0:
        return int(math.ceil(t_end / dt - 1e-9))
    k = math.ceil(math.log(dt_max / dt) / math.log(growth))  # steps until the step reaches dt_max
    ramp = dt * (growth**k - 1.0) / (growth - 1.0)
    if ramp >= t_end:
        return int(math.ceil(math.log(1.0 + t_end * (growth - 1.0) / dt) / math.log(growth)))
    return int(k + math.ceil((t_end - ramp) / dt_max - 1e-9))


@dataclass(frozen=True)
class Cost:
    """Estimated cost of one run.

    what : str, the run (e.g. ``"solve grease"``)
    cells, unknowns : int [-] mesh cells and nodes (one temperature unknown per node)
    steps : int [-] transient time steps (0: steady only)
    saved : int [-] whole fields kept for output
    memory_bytes : float [bytes] estimated peak resident memory
    """

    what: str
    cells: int
    unknowns: int
    steps: int
    saved: int
    memory_bytes: float

    def describe(self) -> str:
        parts = [f"{self.cells:,} cells", f"{self.unknowns:,} unknowns"]
        if self.steps:
            parts.append(f"{self.steps:,} time steps")
        if self.saved > 1:
            parts.append(f"{self.saved:,} saved fields")
        return f"{', '.join(parts)}, ~{fmt_bytes(self.memory_bytes)}"


def thermal_cost(what: str, shape, *, steps: int = 0, saved: int = 1, geometry_only: bool = False) -> Cost:
    """Cost of meshing (``geometry_only``) or solving a mesh of ``shape`` = (nx, ny, nz) cells."""
    nx, ny, nz = (int(v) for v in shape)
    cells, nodes = nx * ny * nz, (nx + 1) * (ny + 1) * (nz + 1)
    per = BYTES_PER_UNKNOWN_GEOMETRY if geometry_only else BYTES_PER_UNKNOWN_SOLVE
    mem = BASE_BYTES + per * nodes + BYTES_PER_SAVED_VALUE * nodes * max(saved - 1, 0)
    return Cost(what, cells, nodes, int(steps), int(saved), float(mem))


#: peak resident memory of a mesh-error estimate per node of its refined mesh [bytes] (the refined problem's
#: conduction and linear laws in one data array, assembled in slabs of node planes, its pattern; the prolongation
#: applied as three 1-D interpolations; no AMG hierarchy of its own: :func:`imutherm.thermal.refinement.refined_steady`).
#: Measured ~0.36 kB above BASE_BYTES (the worker's refined-solve stage of ``benchmarks/bench_thermal_case_memory.py``,
#: the coarse scheme's solve and the process included: 671 MiB at 1.59e6 refined nodes, the reference unit's grease
#: scheme, 649-665 MiB for air at 1.51e6; 2026-12-08, after issue 59's matrix-free refined solve; 0.69 kB before it,
#: 1.9 kB before the refined assembly's memory was cut); rounded up. ``compare``'s side-by-side estimate with it
#: (:func:`imutherm.studies.cost.check_schemes_side_by_side`) is 1.73e9 bytes against 1.53e9 measured (1462 MiB).
BYTES_PER_REFINED_UNKNOWN = 500


def refined_cost(what: str, shape, ratio: int = 2) -> Cost:
    """Cost of the mesh-error estimate's steady solve on the mesh of ``shape`` (nx, ny, nz) cells with every
    interval split in ``ratio`` parts."""
    nx, ny, nz = (int(v) * ratio for v in shape)
    nodes = (nx + 1) * (ny + 1) * (nz + 1)
    return Cost(what, nx * ny * nz, nodes, 0, 1, float(BASE_BYTES + BYTES_PER_REFINED_UNKNOWN * nodes))


def check_cost(cost: Cost, max_memory: int | None, hint: str = "use a larger --mesh-size or a smaller --min-cells"):
    """InputError stating the estimate and the limit if ``cost`` is beyond what this run may use."""
    limit = available_memory_bytes() if max_memory is None else int(max_memory)
    src = "--max-memory" if max_memory is not None else "the memory available now (--max-memory)"
    if cost.steps > MAX_TIME_STEPS:
        raise InputError(f"{cost.what}: estimated {cost.steps:,} time steps exceed the limit of {MAX_TIME_STEPS:,}; "
                         "use a shorter --t-end or a larger --dt / --dt-max")
    if cost.saved > MAX_SAVED_FIELDS:
        raise InputError(f"{cost.what}: {cost.saved:,} saved fields exceed the limit of {MAX_SAVED_FIELDS:,}; "
                         "use a larger --save-every")
    if cost.cells > MAX_CELLS:
        raise InputError(f"{cost.what}: estimated {cost.describe()}: {cost.cells:,} cells exceed the limit of "
                         f"{MAX_CELLS:,}; {hint}")
    if cost.memory_bytes > limit:
        raise InputError(f"{cost.what}: estimated {cost.describe()} of memory, more than {src} "
                         f"{fmt_bytes(limit)}; {hint}")
    return cost


def check_memory(what: str, memory_bytes: float, max_memory: int | None, hint: str) -> float:
    """InputError ``"<what>: estimated ~X of memory, more than <limit>; <hint>"`` beyond ``max_memory`` [bytes]
    (None: the memory available now); returns ``memory_bytes``."""
    limit = available_memory_bytes() if max_memory is None else int(max_memory)
    if memory_bytes > limit:
        src = "--max-memory" if max_memory is not None else "the memory available now (--max-memory)"
        raise InputError(f"{what}: estimated ~{fmt_bytes(memory_bytes)} of memory, more than {src} "
                         f"{fmt_bytes(limit)}; {hint}")
    return float(memory_bytes)


#: peak memory per motion sample of ``imutherm attitude`` [bytes]: measured ~0.9 kB (600 s vs 200 s of the
#: flight profile at 100 Hz: 190 vs 138 MiB), rounded up with margin; the first seed's series is kept
BYTES_PER_SAMPLE_ATTITUDE = 1500
#: most samples x seeds of one attitude run: 1e8 are ~1.6 h at the measured ~57 us per sample and seed
MAX_SAMPLE_SEEDS = 100_000_000


def check_attitude_cost(duration_s: float, rate_hz: float, seeds: int, max_memory: int | None) -> Cost:
    """InputError if ``seeds`` runs of ``duration_s`` [s] at ``rate_hz`` [Hz] are beyond the limits."""
    samples = int(min(duration_s * rate_hz, 1e18))
    cost = Cost("attitude", 0, 0, 0, 0, float(BASE_BYTES + BYTES_PER_SAMPLE_ATTITUDE * samples))
    limit = available_memory_bytes() if max_memory is None else int(max_memory)
    src = "--max-memory" if max_memory is not None else "the memory available now (--max-memory)"
    if samples * seeds > MAX_SAMPLE_SEEDS:
        raise InputError(f"attitude: --duration {duration_s:g} s at {rate_hz:g} Hz x --seeds {seeds} = "
                         f"{samples * seeds:.3g} samples, more than the limit of {MAX_SAMPLE_SEEDS:.0e}; "
                         "use a shorter --duration or fewer --seeds")
    if cost.memory_bytes > limit:
        raise InputError(f"attitude: --duration {duration_s:g} s at {rate_hz:g} Hz is {samples:,} samples, "
                         f"estimated ~{fmt_bytes(cost.memory_bytes)} of memory, more than {src} {fmt_bytes(limit)}; "
                         "use a shorter --duration")
    return cost


# ------------------------------------------------------------------ the s2s cavity law
#: peak memory of the s2s exchange above the mesh and its patches [bytes]: a fixed part plus its dense n x n
#: arrays (ray counts, view factors, the radiosity system and its solution, X) per pair of patches. Fitted by
#: benchmarks/bench_cost_model.py (reference unit, grease, 3 mm mesh, 400 rays; 645 / 1302 / 2507 / 5287
#: patches: +57 / 104 / 339 / 1334 MiB): ~46 bytes per pair + ~50 MiB, rounded up to 56 and 64 MiB
BYTES_PER_PATCH_PAIR = 56.0
S2S_BASE_BYTES = 64 * 2**20
#: CPU time of the s2s exchange [s]: per ray cast (view factors), per patch pair (the reciprocity and
#: closure balancing) and per patch cubed (the dense radiosity solve). Fitted (non-negative least squares,
#: relative error) by benchmarks/bench_cost_model.py on the same four sizes: 2.5 / 5.5 / 14.9 / 56.6 s of
#: CPU, on a machine shared with five other jobs (2026-12-01)
SECONDS_PER_RAY = 8.5e-6
SECONDS_PER_PATCH_PAIR = 5.5e-7
SECONDS_PER_PATCH_CUBE = 1.6e-10
#: most estimated CPU time of the s2s exchange of one run [s]: an hour (the default 5 mm patches of the
#: reference unit take seconds); more is a patch size typed wrong, e.g. ``--cavity-patch-mm 0.001``
MAX_S2S_S = 3600.0
#: most s2s patches whatever the memory: the patch-size convergence study (docs/benchmarks/cavity_radiation.md) has the reference unit's sites within
#: 0.1 K at 2 mm patches (~5,600 at the default mesh); 1e4 patches are ~5.3 GiB and ~4 min of CPU here, and
#: more only repeats face cells (a patch never gets smaller than its mesh face)
MAX_PATCHES = 10_000


def s2s_cost(n_patches: int, rays: int) -> tuple:
    """(memory [bytes], CPU time [s]) of the s2s exchange of ``n_patches`` patches at ``rays`` rays each."""
    n = float(n_patches)
    seconds = SECONDS_PER_RAY * n * rays + SECONDS_PER_PATCH_PAIR * n**2 + SECONDS_PER_PATCH_CUBE * n**3
    return S2S_BASE_BYTES + BYTES_PER_PATCH_PAIR * n**2, seconds


def check_s2s_cost(what: str, n_patches: int, rays: int, max_memory: int | None = None,
                   other_bytes: float = 0.0) -> tuple:
    """InputError stating the patches, the estimate and the limit if the s2s exchange is beyond
    :data:`MAX_PATCHES`, :data:`MAX_S2S_S` or, with ``other_bytes`` (the rest of the run), beyond ``max_memory`` (None: the memory
    available now); returns (memory [bytes], seconds)."""
    mem, sec = s2s_cost(n_patches, rays)
    hint = "use a larger --cavity-patch-mm (or --cavity-law effective)"
    desc = f"{what}: {n_patches:,} cavity patches (dense exchange: n^2 memory, n^3 time)"
    if n_patches > MAX_PATCHES:
        raise InputError(f"{desc}, estimated ~{fmt_bytes(mem)} and ~{sec:,.0f} s of CPU: more than the limit of "
                         f"{MAX_PATCHES:,} patches; {hint}")
    if sec > MAX_S2S_S:
        raise InputError(f"{desc}, estimated ~{sec / 3600:,.3g} h of CPU and ~{fmt_bytes(mem)}, more than the limit of "
                         f"{MAX_S2S_S / 3600:g} h; {hint}")
    check_memory(f"{desc} and the rest of the run", mem + other_bytes, max_memory, hint)
    return mem, sec
