"""Verification suite of the thermal FEM core: analytic solutions and NAFEMS benchmarks.

Each case builds a :class:`ThermalProblem`, solves it with the production
solvers and compares with a closed form or a published benchmark value. It
returns a :class:`VerificationRecord` stating the tolerance and why that
tolerance is right for the case (round-off only where Q1 is nodally exact,
discretisation error estimates elsewhere). A case that raises is recorded as a
failure with its message, and the suite goes on (:func:`run_all`).

Cases (``CASES``):

1. ``slab_generation``      1-D slab, uniform generation, fixed temperatures
2. ``composite_wall``       two materials + contact layer, convection both sides
3. ``transient_slab``       plane wall with convection, series with ζ tan ζ = Bi
4. ``semi_infinite``        semi-infinite solid, surface convection (erfc)
5. ``lumped_capacitance``   high-k block with power, small Bi; also checks t63
6. ``nafems_t3``            NAFEMS T3 1-D transient (36.6 °C at x = 0.08 m, 32 s)
7. ``nafems_t4``            NAFEMS T4 2-D convection (18.25 °C at E)
8. ``radiation_1d``         1-D conduction with radiating end (927 K)
9. ``mms_convergence``      manufactured solution, non-uniform 3-D grid, L2 rate ≈ 2
10. ``orthotropic_plate``   orthotropic rectangle with generation, series solution
11. ``lumped_backward_euler`` case 5 with backward Euler (θ = 1): observed temporal order ≈ 1
12. ``natural_convection_1d`` 1-D wall, nonlinear natural convection (+ radiation) end, brentq
13. ``lumped_trbdf2``       case 5 with TR-BDF2, fixed steps: observed temporal order ≈ 2
14. ``lumped_trbdf2_adaptive`` case 5 with adaptive TR-BDF2: error and t63/t95 within the control's target
15. ``refinement_board_cavity`` 2-D board in an air cavity: the study's two-grid mesh-error estimate brackets
    the converged value (extrapolated from grids 4x-16x finer)

The package: :mod:`~imutherm.thermal.verification.record` (the record, the reference values, the grids),
:mod:`~imutherm.thermal.verification.steady` and :mod:`~imutherm.thermal.verification.transient` (the cases),
:mod:`~imutherm.thermal.verification.board_cavity` (the mesh-error case); :data:`CASES`, :func:`run_case` and
:func:`run_all` here, with the names the tests and the mesh-convergence study use.
"""

from __future__ import annotations

import time

from imutherm.thermal.verification.board_cavity import (BOARD_CAVITY_AMBIENT_C, BOARD_CAVITY_DEPTH_MM,  # noqa: F401
                                                         BOARD_CAVITY_PARTS, BOARD_CAVITY_POWER_W, EFFECTIVITY_RANGE,
                                                         board_cavity_grid, board_cavity_solve,
                                                         case_refinement_board_cavity)
from imutherm.thermal.verification.record import (NAFEMS_T3_TARGET_C, NAFEMS_T4_ROUNDING_K,  # noqa: F401
                                                   NAFEMS_T4_TARGET_C, RADIATION_1D_PUBLISHED_K, VerificationRecord,
                                                   checked, box_grid, graded)
from imutherm.thermal.verification.steady import (l2_error, case_composite_wall, case_mms_convergence,  # noqa: F401
                                                   case_nafems_t4, case_natural_convection_1d, case_orthotropic_plate,
                                                   case_radiation_1d, case_slab_generation,
                                                   orthotropic_rectangle_centre)
from imutherm.thermal.verification.transient import (lumped_block, semi_discrete_exact,  # noqa: F401
                                                      case_lumped_backward_euler, case_lumped_capacitance,
                                                      case_lumped_trbdf2, case_lumped_trbdf2_adaptive, case_nafems_t3,
                                                      case_semi_infinite, case_transient_slab, nafems_t3_series,
                                                      semi_infinite_convection, slab_convection_series)


CASES = {
    "slab_generation": case_slab_generation,
    "composite_wall": case_composite_wall,
    "transient_slab": case_transient_slab,
    "semi_infinite": case_semi_infinite,
    "lumped_capacitance": case_lumped_capacitance,
    "nafems_t3": case_nafems_t3,
    "nafems_t4": case_nafems_t4,
    "radiation_1d": case_radiation_1d,
    "mms_convergence": case_mms_convergence,
    "orthotropic_plate": case_orthotropic_plate,
    "lumped_backward_euler": case_lumped_backward_euler,
    "natural_convection_1d": case_natural_convection_1d,
    "lumped_trbdf2": case_lumped_trbdf2,
    "lumped_trbdf2_adaptive": case_lumped_trbdf2_adaptive,
    "refinement_board_cavity": case_refinement_board_cavity,
}


def run_case(name: str, cases: dict | None = None) -> VerificationRecord:
    """Run one case of ``cases`` (default :data:`CASES`); an exception becomes a failed record carrying its
    message."""
    t0 = time.perf_counter()
    try:
        return (CASES if cases is None else cases)[name]()
    except Exception as exc:  # noqa: BLE001 - recorded, the suite goes on
        return VerificationRecord(case=name, quantity="", computed=float("nan"), exact=float("nan"),
                                  error=float("nan"), tolerance=float("nan"), passed=False,
                                  note=f"raised {type(exc).__name__}: {exc}", seconds=time.perf_counter() - t0)


def run_all(cases=None, registry: dict | None = None) -> list:
    """Run the named cases (default all of ``registry``, default :data:`CASES`, in order); their records."""
    registry = CASES if registry is None else registry
    names = list(registry) if cases is None else list(cases)
    return [run_case(n, registry) for n in names]
