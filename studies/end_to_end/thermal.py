"""The thermal side of the end-to-end study: one scheme's steady field, power-on transient and self-heating in
the calibration oven (:func:`thermal_case`), and the order the schemes go to the workers.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from imutherm import InputError
from imutherm.geometry.layout import LayoutSpec
from imutherm.unit.model import ModelOptions, build_problem
from imutherm.thermal.steady import solve_steady
from imutherm.studies.thermal_study import longest_first, with_mesh_error  # noqa: F401  (the package's names)


def self_heating_table(res, chamber_C, *, model: str = "full", solves: list | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Sensor-die rise over the chamber [K], (k, 6) in SITES order, at oven temperatures ``chamber_C`` [°C].

    The scheme's model is solved steady with the chamber as ambient and fixture
    temperature (same mesh and options as ``res``); a chamber equal to the
    layout's ambient reuses ``res.steady``. ``model`` 'full': the full Newton solve; 'reduced': on a basis of
    ``res``'s steady rise that checks itself against the full model, every sensor die within 0.01 K
    (:func:`imutherm.thermal.reduced_steady.reduced_steady`), the full solve when the check fails.
    ``solves``: a list that gets one JSON-ready dict per solved chamber temperature (how it was solved).
    """
    from imutherm.imu.sensor_model import SITES
    from imutherm.thermal.assembly import assemble
    from imutherm.thermal.reduced_steady import reduced_steady

    geo = res.geometry
    lay = geo.layout
    missing = [s for s in SITES if s not in geo.sites]
    if missing:
        raise InputError(f"{lay.path}: the study needs a site per sensor die; missing: {', '.join(missing)}")
    probes = {s: geo.sites[s] for s in SITES}
    chamber = np.asarray(sorted(float(c) for c in chamber_C))
    rise = np.empty((chamber.size, 6))
    for k, Tc in enumerate(chamber):
        if Tc == lay.ambient_C and lay.mounting.temperature_C == lay.ambient_C:
            st = res.steady
            idx = [st.probe_names.index(s) for s in SITES]
            rise[k] = np.asarray(st.probe_C)[idx] - Tc
            continue
        lay_c = replace(lay, ambient_C=Tc, mounting=replace(lay.mounting, temperature_C=Tc))
        problem = build_problem(replace(geo, layout=lay_c), res.grid, res.options)
        asm = assemble(problem)
        known = np.asarray(res.steady.T_C) - lay.ambient_C
        st, how = None, {"chamber_C": float(Tc), "model": "full"}
        if model == "reduced":
            try:
                st, chk = reduced_steady(problem, asm, known, probes)
                how["check"] = chk.summary()
            except InputError as e:   # e.g. a fixed-temperature face: the full solve
                how["check"] = {"accepted": False, "reason": str(e)}
            if st is not None:
                how["model"] = "reduced"
        if st is None:
            st = solve_steady(problem, probes=probes, initial_C=known + Tc, assembly=asm)
        if solves is not None:
            solves.append(how)
        rise[k] = np.asarray(st.probe_C) - Tc
    return chamber, rise


def site_curves(res) -> tuple[np.ndarray, np.ndarray]:
    """Die temperatures of the six sensor sites over the power-on transient: t (M,) [s], T (M, 6) [°C]."""
    from imutherm.imu.sensor_model import SITES

    tr = res.transient
    idx = [tr.probe_names.index(s) for s in SITES]
    return np.asarray(tr.times, float), np.asarray(tr.probe_C, float)[:, idx]


def thermal_case(layout: LayoutSpec, scheme: str, options: ModelOptions, chamber_C, progress: bool = False,
                 **thermal_kwargs):
    """The thermal side of one scheme: (SchemeResult, chamber (k,) [°C], rise (k, 6) [K], oven solves).

    Steady field, power-on transient (always run) and the oven self-heating table; a pure function of its
    arguments, so schemes can run in separate processes. With ``estimate_mesh_error``, the sites' values and
    curves and the oven's rises are the estimate's corrected answer
    (:func:`~imutherm.studies.thermal_study.mesh_corrected`). The oven solves are reduced and checked when the
    transient is (``transient_model`` 'reduced'), else full. Returns (SchemeResult, chamber, rise, oven solves
    (list of dicts, :func:`self_heating_table`)).
    """
    from imutherm.budget import release_freed_memory
    from imutherm.imu.sensor_model import SITES
    from imutherm.studies.thermal_study import mesh_factors, run_scheme

    estimate = thermal_kwargs.pop("estimate_mesh_error", False)
    res = run_scheme(layout, scheme, options=options, progress=progress, transient=True, **thermal_kwargs)
    solves = []
    chamber, rise = self_heating_table(res, chamber_C, model=thermal_kwargs.get("transient_model", "full"),
                                       solves=solves)
    if estimate:
        res = with_mesh_error(res)
        factors = mesh_factors(res)   # the oven's rises too: the same mesh, the same conduction
        rise = rise * np.array([factors.get(s, 1.0) for s in SITES])
    release_freed_memory()
    return res, chamber, rise, solves
