"""Thermal finite elements on the tensor grid: problem, boundary laws, assembly, solvers.

The solver knows nothing about layouts: build a :class:`ThermalProblem` from a
:class:`~imutherm.geometry.grid.TensorGrid` and cell fields, then call
:func:`solve_steady` or :func:`solve_transient`.
"""

from imutherm.thermal.assembly import Assembly, assemble
from imutherm.thermal.metrics import ThermalMetrics, settle_time, thermal_metrics
from imutherm.thermal.output import write_pvd, write_result, write_vtu
from imutherm.thermal.problem import (SIGMA, Contact, Convection, FixedTemperature, HeatFlux, NaturalConvection,
                                      Radiation, ThermalProblem, contact_layer_conductivity, fields_from_parts,
                                      natural_convection_C, natural_convection_h, radiation_flux)
from imutherm import ConvergenceError
from imutherm.thermal.probes import probe_matrix
from imutherm.thermal.results import SteadyResult, ThermalResult, TransientResult
from imutherm.thermal.steady import solve_steady
from imutherm.thermal.transient import solve_transient, time_steps

__all__ = [
    "Assembly", "assemble", "ThermalMetrics", "settle_time", "thermal_metrics", "write_pvd", "write_result",
    "write_vtu", "SIGMA", "Contact", "Convection", "FixedTemperature", "HeatFlux", "NaturalConvection",
    "Radiation", "ThermalProblem", "contact_layer_conductivity", "fields_from_parts", "natural_convection_h",
    "natural_convection_C", "radiation_flux", "ConvergenceError", "ThermalResult", "SteadyResult", "TransientResult",
    "probe_matrix", "solve_steady", "solve_transient", "time_steps",
]
