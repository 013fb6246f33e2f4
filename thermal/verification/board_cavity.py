"""The verification suite's mesh-error case: a 2-D board in an air cavity, where the study's two-grid
Richardson estimate must bracket the value extrapolated from grids 4x-16x finer.
"""

from __future__ import annotations

import time

import numpy as np

from imutherm.geometry.grid import TensorGrid
from imutherm.thermal.problem import Convection, ThermalProblem
from imutherm.thermal.steady import solve_steady
from imutherm.thermal.verification.record import VerificationRecord, checked


#: the board-in-cavity cross-section of case 15: (name, (x0, x1), (z0, z1)) [mm], k (kx, ky, kz) [W/m K],
#: painted in this order (later parts over earlier). A 2-D slice (one cell deep, adiabatic front and back) of
#: the reference unit's main board: Al housing, air, an FR4 board 1 mm from the side walls on nylon standoffs,
#: a mould package with a silicon die
BOARD_CAVITY_PARTS = (
    ("housing", (0.0, 50.0), (0.0, 20.0), (167.0, 167.0, 167.0)),
    ("air", (2.5, 47.5), (3.0, 17.0), (0.026, 0.026, 0.026)),
    ("standoff_1", (5.0, 8.0), (3.0, 6.0), (0.25, 0.25, 0.25)),
    ("standoff_2", (42.0, 45.0), (3.0, 6.0), (0.25, 0.25, 0.25)),
    ("board", (3.5, 46.5), (6.0, 7.6), (20.0, 20.0, 0.4)),
    ("package", (20.0, 27.0), (7.6, 9.2), (0.7, 0.7, 0.7)),
    ("die", (22.0, 25.0), (7.8, 8.1), (150.0, 150.0, 150.0)),
)


BOARD_CAVITY_POWER_W = 0.3       # in the die, over the 10 mm depth of the slice


BOARD_CAVITY_DEPTH_MM = 10.0


BOARD_CAVITY_AMBIENT_C = 70.0


#: the effectivity (estimated / true error) case 15 accepts: the estimate must bound the error (>= 1) without
#: overstating it more than 3x
EFFECTIVITY_RANGE = (1.0, 3.0)


def board_cavity_grid(factor: int = 1) -> TensorGrid:
    """The board-in-cavity slice on lines at every part face, each interval split into max(2, ceil(w / 2 mm))
    cells (every part and every gap >= 2 cells, the study mesh's rule), then each into ``factor`` more along x
    and z (the slice stays one cell deep)."""
    def axis(i):
        faces = np.unique([v for _, *ext, _ in BOARD_CAVITY_PARTS for v in ext[i]])
        pieces = [np.linspace(a, b, max(2, int(np.ceil((b - a) / 2.0 - 1e-9))) * factor + 1)[:-1]
                  for a, b in zip(faces[:-1], faces[1:])]
        return np.concatenate(pieces + [faces[-1:]]) * 1e-3
    xs, zs = axis(0), axis(1)
    cp = np.zeros((len(xs) - 1, 1, len(zs) - 1), dtype=int)
    xc, zc = 0.5 * (xs[1:] + xs[:-1]) * 1e3, 0.5 * (zs[1:] + zs[:-1]) * 1e3
    for i, (_, (x0, x1), (z0, z1), _) in enumerate(BOARD_CAVITY_PARTS):
        cp[np.ix_((xc > x0) & (xc < x1), [0], (zc > z0) & (zc < z1))] = i
    return TensorGrid(xs, np.array([0.0, BOARD_CAVITY_DEPTH_MM * 1e-3]), zs, cp,
                      tuple(p[0] for p in BOARD_CAVITY_PARTS), {})


def board_cavity_solve(grid: TensorGrid, points) -> np.ndarray:
    """(die centre, board top at x = 40 mm, hot spot) [°C] of the slice on ``grid``: the base held by a 500
    W/m² K contact to 70 °C (the fixture), the other outer faces 10 W/m² K to 70 °C."""
    k = np.array([p[3] for p in BOARD_CAVITY_PARTS])[grid.cell_part].reshape(-1, 3)
    die = grid.part_names.index("die")
    vol = grid.cell_volumes()
    q = np.where(grid.cell_part == die, BOARD_CAVITY_POWER_W / vol[grid.cell_part == die].sum(), 0.0)
    laws = {f: Convection(10.0, BOARD_CAVITY_AMBIENT_C) for f in ("xmin", "xmax", "zmax")}
    laws["zmin"] = Convection(500.0, BOARD_CAVITY_AMBIENT_C)
    r = solve_steady(ThermalProblem(grid, k, 1.0, q.reshape(-1), BOARD_CAVITY_AMBIENT_C, laws),
                     probes=list(points.items()),
                     solver="direct")   # a 2-D slice factorises cheaply (AMG took 10x longer at 16x)
    return np.append(np.asarray(r.probe_C), float(np.max(r.T_C)))


def case_refinement_board_cavity(reference=(4, 8, 16)) -> VerificationRecord:
    """Board-in-cavity slice: the study's two-grid mesh-error estimate against a converged reference.

    The error of the base grid's die temperature is estimated as the study estimates it (the base grid and the
    grid with every interval split in two, Richardson with the assumed order
    :data:`~imutherm.thermal.refinement.MESH_ERROR_ORDER`); the reference is the Richardson extrapolation of
    grids 4x, 8x and 16x finer (their observed order; 32x lands within 0.01 K of it). The estimate passes when
    it brackets the reference
    (the base value plus the estimate lies beyond it, on the same side) without overstating the error more
    than 3x.
    """
    from imutherm.thermal.refinement import MESH_ERROR_ORDER, observed_order, richardson

    t0 = time.perf_counter()
    pts = {"die": (23.5e-3, 5e-3, 7.95e-3), "board": (40e-3, 5e-3, 7.6e-3)}
    base, fine = (board_cavity_solve(board_cavity_grid(f), pts) for f in (1, 2))
    levels = np.array([board_cavity_solve(board_cavity_grid(f), pts) for f in reference])
    p_ref = observed_order(levels, reference)
    ref = levels[-1] + (levels[-1] - levels[-2]) / ((reference[-1] / reference[-2]) ** p_ref - 1.0)
    est, _ = richardson(base, fine, 2, MESH_ERROR_ORDER)
    true = ref - base
    eff = est / true
    lo, hi = EFFECTIVITY_RANGE
    outside = float(np.max(np.maximum(0.0, np.maximum(lo - eff, eff - hi))))
    i = 0   # the die: the quantity recorded
    rise = base[i] - BOARD_CAVITY_AMBIENT_C
    nx, _, nz = board_cavity_grid(1).shape
    gap = BOARD_CAVITY_PARTS[4][1][0] - BOARD_CAVITY_PARTS[1][1][0]   # board edge to wall [mm]
    return checked("refinement_board_cavity", "estimated / true error of the base grid's die temperature [-]",
                   float(eff[i]), 1.0, outside, 0.0,
                   f"2-D board in an air cavity ({len(BOARD_CAVITY_PARTS)} parts, {BOARD_CAVITY_POWER_W:g} W die, "
                   f"gaps of {gap:g} mm); base grid {nx}x{nz} cells, die rise {rise:.3f} K; reference: grids "
                   f"{', '.join(f'{f}x' for f in reference)} finer, observed order "
                   f"{', '.join(f'{v:.2f}' for v in p_ref)} (die, board, hot spot), extrapolated "
                   f"{', '.join(f'{v:.4f}' for v in ref)} °C ({reference[-1]}x within "
                   f"{np.max(np.abs(ref - levels[-1])):.2g} K of it); true errors of the base grid "
                   f"{', '.join(f'{v:+.4f}' for v in true)} K, two-grid estimates (p {MESH_ERROR_ORDER:g}) "
                   f"{', '.join(f'{v:+.4f}' for v in est)} K: effectivity {', '.join(f'{v:.2f}' for v in eff)}; "
                   f"pass: every effectivity in [{lo:g}, {hi:g}] (the estimate brackets the reference without "
                   f"overstating the error more than {hi:g}x; the error recorded is the largest distance outside "
                   "that interval)", t0)
