"""Export a linear :class:`ThermalProblem` to CalculiX (``ccx``) and read the result back.

The deck uses the same discretisation as :mod:`imutherm.thermal.steady`:
8-node heat-transfer bricks ``DC3D8`` on the grid nodes (node id = grid node
index + 1, element id = cell index + 1), one ``*MATERIAL`` per distinct
(kx, ky, kz, rho_c) with ``*CONDUCTIVITY, TYPE=ORTHO`` (three values in the
global axes: ccx 2.20 ``conductivitys.f`` reads k11, k22, k33 for ORTHO),
``*DENSITY`` = rho_c and ``*SPECIFIC HEAT`` = 1 (only their product matters),
``*DFLUX ... BF`` for the volumetric power [W/m^3], ``*FILM ... Fn`` for
Convection and Contact, ``*DFLUX ... Sn`` for HeatFlux (positive into the
solid) and ``*BOUNDARY`` degree of freedom 11 for fixed temperatures. Only
linear laws are exported; NaturalConvection and Radiation raise
:class:`~imutherm.InputError`.

Face labels of the 8-node brick (ccx manual, "Three-dimensional elements",
node order 1-2-3-4 bottom, 5-6-7-8 top as in VTK): F1 = 1-2-3-4 (zmin),
F2 = 5-8-7-6 (zmax), F3 = 1-5-6-2 (ymin), F4 = 2-6-7-3 (xmax),
F5 = 3-7-8-4 (ymax), F6 = 4-8-5-1 (xmin). Temperatures are written in °C
(the problem is linear, so the unit offset is irrelevant).
"""

from __future__ import annotations

import os
import resource
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from imutherm import InputError
from imutherm.thermal.assembly import faces
from imutherm.thermal.problem import (LINEAR_LAWS, NONLINEAR_LAWS, FixedTemperature, HeatFlux,
                                      ThermalProblem)

#: outer face name -> ccx face label of the DC3D8 element
FACE_LABEL = {"zmin": 1, "zmax": 2, "ymin": 3, "xmax": 4, "ymax": 5, "xmin": 6}


def _face_cells(grid, name: str, mask: np.ndarray) -> np.ndarray:
    """Flat cell indices (C order) of the boundary cells under the selected face cells of ``name``."""
    nx, ny, nz = grid.shape
    cid = np.arange(grid.n_cells).reshape(nx, ny, nz)
    d = "xyz".index(name[0])
    idx = [slice(None)] * 3
    idx[d] = 0 if name.endswith("min") else -1
    return cid[tuple(idx)][mask]


def _lines(values, per_line: int = 8):
    vals = [str(int(v)) for v in values]
    for i in range(0, len(vals), per_line):
        yield ", ".join(vals[i:i + per_line]) + ("," if i + per_line < len(vals) else "")


def write_ccx_deck(problem: ThermalProblem, path) -> Path:
    """Write a CalculiX steady heat-transfer deck for ``problem``.

    Parameters
    ----------
    problem : ThermalProblem
        Only FixedTemperature (constant), Convection, Contact and HeatFlux laws.
    path : str or Path
        Target ``.inp`` file.

    Returns
    -------
    Path of the deck.
    """
    g = problem.grid
    if problem.exchanges:
        raise InputError("write_ccx_deck: the problem has an interior exchange (s2s cavity radiation), which is "
                         "not exported; use cavity_law 'effective' or 'none'")
    for face, laws in problem.boundary.items():
        for law in laws:
            if isinstance(law, NONLINEAR_LAWS):
                raise InputError(f"write_ccx_deck: face {face!r}: {type(law).__name__} is nonlinear; only "
                                 f"FixedTemperature, Convection, Contact and HeatFlux are exported")
            if isinstance(law, FixedTemperature) and callable(law.T_C):
                raise InputError(f"write_ccx_deck: face {face!r}: time-dependent FixedTemperature is not exported")
    path = Path(path)
    X = g.node_coordinates()
    conn = g.hex_connectivity() + 1
    props = np.column_stack([problem.k, problem.rho_c])
    mats, mat_of_cell = np.unique(props, axis=0, return_inverse=True)
    mat_of_cell = mat_of_cell.reshape(-1)
    out = ["*HEADING", "imutherm thermal export (SI units, temperatures in degC)"]
    out.append("*NODE, NSET=NALL")
    out += [f"{i + 1}, {x:.17g}, {y:.17g}, {z:.17g}" for i, (x, y, z) in enumerate(X)]
    out.append("*ELEMENT, TYPE=DC3D8, ELSET=EALL")
    out += [f"{e + 1}, " + ", ".join(str(int(n)) for n in row) for e, row in enumerate(conn)]
    for m in range(len(mats)):
        out.append(f"*ELSET, ELSET=EM{m + 1}")
        out += list(_lines(np.flatnonzero(mat_of_cell == m) + 1, 16))
    for m, (kx, ky, kz, rc) in enumerate(mats):
        out += [f"*MATERIAL, NAME=M{m + 1}", "*CONDUCTIVITY, TYPE=ORTHO", f"{kx:.17g}, {ky:.17g}, {kz:.17g}",
                "*DENSITY", f"{rc:.17g}", "*SPECIFIC HEAT", "1.0",
                f"*SOLID SECTION, ELSET=EM{m + 1}, MATERIAL=M{m + 1}"]
    out += ["*INITIAL CONDITIONS, TYPE=TEMPERATURE", f"NALL, {problem.ambient_C:.17g}"]
    out += ["*STEP", "*HEAT TRANSFER, STEADY STATE", "1.0, 1.0"]
    fcs = faces(g)
    fixed, films, sflux = {}, [], []
    for name in ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax"):
        for law in problem.boundary.get(name, ()):
            face = fcs[name]
            mask = face.mask(law.region)
            if isinstance(law, FixedTemperature):
                for n_ in np.unique(face.corner_nodes(mask)).tolist():
                    fixed[n_] = law.value(None)
            elif isinstance(law, LINEAR_LAWS):
                T_ref = problem.law_T_C(law)
                for c in _face_cells(g, name, mask):
                    films.append(f"{c + 1}, F{FACE_LABEL[name]}, {T_ref:.17g}, {law.coefficient:.17g}")
            elif isinstance(law, HeatFlux):
                for c in _face_cells(g, name, mask):
                    sflux.append(f"{c + 1}, S{FACE_LABEL[name]}, {law.q:.17g}")
    if fixed:
        out.append("*BOUNDARY")
        out += [f"{n_ + 1}, 11, 11, {v:.17g}" for n_, v in sorted(fixed.items())]
    if films:
        out.append("*FILM")
        out += films
    powered = np.flatnonzero(problem.q != 0)
    if len(powered) or sflux:
        out.append("*DFLUX")
        out += [f"{c + 1}, BF, {problem.q[c]:.17g}" for c in powered]
        out += sflux
    out += ["*NODE FILE", "NT", "*END STEP", ""]
    path.write_text("\n".join(out))
    return path


def read_frd_temperatures(path, n_nodes: int) -> np.ndarray:
    """Nodal temperatures (last NDTEMP block) from a CalculiX ``.frd`` file.

    Returns
    -------
    ndarray (n_nodes,) [°C], grid node order (ccx node id − 1).
    """
    T = None
    block = None
    with open(path) as fh:
        for line in fh:
            if line.startswith(" -4") and "NDTEMP" in line:
                block = np.full(n_nodes, np.nan)
                continue
            if block is None:
                continue
            if line.startswith(" -1"):
                node = int(line[3:13])
                block[node - 1] = float(line[13:25])
            elif line.startswith(" -3"):
                T, block = block, None
    if T is None or np.isnan(T).any():
        raise InputError(f"{path}: no complete NDTEMP block in the CalculiX result")
    return T


def ccx_executable() -> str | None:
    """Path of the ``ccx`` executable (env ``IMUTHERM_CCX`` or ``PATH``), or None."""
    exe = os.environ.get("IMUTHERM_CCX") or shutil.which("ccx")
    return exe


def run_ccx(problem: ThermalProblem, *, workdir=None, timeout: float = 600.0, threads: int = 1,
            info: dict | None = None) -> np.ndarray:
    """Solve ``problem`` with CalculiX and return its nodal temperatures [°C] (grid node order).

    Parameters
    ----------
    problem : ThermalProblem
        Linear laws only (see :func:`write_ccx_deck`).
    workdir : str or Path, optional
        Keep the deck and results there (default: a temporary directory, removed).
    timeout : float [s]
    threads : int, OpenMP threads and equation-solver processes given to ccx
    info : dict, optional
        Filled with ``ccx_s`` [s], the wall time of the ccx process alone (no deck
        writing or result parsing), ``ccx_cpu_s`` [s] its CPU time (user + sys, all its threads),
        and ``ccx_peak_MB`` [MB], the peak resident
        memory of the largest child process of this process so far (ccx's own when
        it is the only one, as in ``benchmarks/bench_reference.py``).
    """
    if int(threads) != threads or threads < 1:
        raise InputError(f"threads must be a whole number >= 1, got {threads!r}")
    exe = ccx_executable()
    if exe is None:
        raise InputError("CalculiX 'ccx' not found on PATH (or set IMUTHERM_CCX)")
    tmp = None
    if workdir is None:
        tmp = tempfile.mkdtemp(prefix="imutherm_ccx_")
        workdir = tmp
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    try:
        write_ccx_deck(problem, workdir / "job.inp")
        env = dict(os.environ, OMP_NUM_THREADS=str(threads), CCX_NPROC_EQUATION_SOLVER=str(threads))
        t0 = time.perf_counter()
        ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        proc = subprocess.run([exe, "-i", "job"], cwd=workdir, capture_output=True, text=True,
                              timeout=timeout, env=env)
        if info is not None:
            ru = resource.getrusage(resource.RUSAGE_CHILDREN)
            info["ccx_s"] = time.perf_counter() - t0
            info["ccx_cpu_s"] = (ru.ru_utime - ru0.ru_utime) + (ru.ru_stime - ru0.ru_stime)
            info["ccx_peak_MB"] = ru.ru_maxrss / 1024
        log = proc.stdout + proc.stderr
        if proc.returncode != 0 or "*ERROR" in log:
            errs = [ln for ln in log.splitlines() if "ERROR" in ln][:5]
            raise InputError(f"ccx failed (exit {proc.returncode}): {' | '.join(errs) or log[-500:]}")
        return read_frd_temperatures(workdir / "job.frd", problem.grid.n_nodes)
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
