"""One case of a sweep on the full FEM: :func:`run_case` and the outputs it records.

:func:`case_outputs` names the thermal outputs of a solved case (largest rise, per-site rises, t95 of the
hottest site) and :func:`attitude_columns` the attitude columns of ``--attitude``; :func:`run_case`
records any failure in the row instead of raising, so a sweep goes on.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    from imutherm.studies.sweep.plan import Case, CaseSettings

def case_outputs(result, sites) -> dict:
    """Outputs of one :class:`~imutherm.studies.thermal.thermal_study.SchemeResult`.

    max_rise_K [K] largest steady rise anywhere; rise_<site>_K [K] steady rise of each site;
    t95_s [s] (transient only) time to 95 % of its final rise of the site with the largest rise
    (None if it has not settled by t_end).
    """
    from imutherm.thermal.metrics import thermal_metrics

    steady = thermal_metrics(result.steady)
    out = {"max_rise_K": float(steady.max_rise_K)}
    if result.transient is not None:
        hottest = max(sites, key=lambda s: steady.probe_rise_K[s])
        t95 = result.metrics.t95_s[hottest]
        out["t95_s"] = None if t95 is None or not math.isfinite(t95) else float(t95)
    out.update({f"rise_{s}_K": float(steady.probe_rise_K[s]) for s in sites})
    return out


def attitude_columns(transient: bool) -> tuple:
    """The attitude columns of a sweep with ``--attitude``: roll and pitch RMS error [deg] of the lean
    IMU configuration :func:`~imutherm.studies.end_to_end.sweep_config` (improved compensation, unit
    calibrated in the oven with this case's self-heating, the registry's sweep filters, flight profile), per
    phase (``warmup`` needs ``transient``; ``steady``), then ``extrapolated_fraction`` [-] (share of
    compensated samples beyond the calibrated range).
    """
    from imutherm.studies.end_to_end import PHASES, sweep_config

    C = sweep_config()

    phases = PHASES if transient else ("steady",)
    return tuple(f"{ph}_{comp}_{f}_{prof}_{m}" for ph in phases for comp in C.compensations for f in C.filters
                 for prof in C.profiles for m in ("roll_rms_deg", "pitch_rms_deg")) + ("extrapolated_fraction",)


def run_case(case: Case, settings: CaseSettings) -> dict:
    """Run one case; any exception is recorded in the row (status ``failed``), never raised."""
    from imutherm.studies.thermal.thermal_study import run_scheme

    start = time.perf_counter()
    row = {"case": case.case_id}
    try:
        res = run_scheme(case.layout, settings.scheme, mesh_size_mm=settings.mesh_size_mm,
                         min_cells=settings.min_cells, options=case.options, transient=settings.transient,
                         t_end=settings.t_end)
        row.update(case_outputs(res, settings.sites))
        if settings.attitude:
            from imutherm.studies.end_to_end import scheme_attitude_metrics

            metrics = scheme_attitude_metrics(res, seeds=settings.attitude_seeds, seed0=0)
            cols = attitude_columns(settings.transient)
            missing = [c for c in cols if c not in metrics]
            if missing:
                raise RuntimeError(f"scheme_attitude_metrics gave no {', '.join(missing)}")
            row.update({c: float(metrics[c]) for c in cols})
        row.update(status="ok", message="")
    except Exception as exc:  # noqa: BLE001 - a failing case is recorded and the sweep goes on
        row.update(status="failed", message=f"{type(exc).__name__}: {' '.join(str(exc).split())}")
    row["seconds"] = time.perf_counter() - start
    return row


def run_pooled_case(case: Case, settings: CaseSettings) -> dict:
    """``run_case`` in a local worker; a worker whose sweep was killed stops instead of running queued cases."""
    from imutherm.workers import parent_gone

    if parent_gone():
        raise SystemExit(0)
    return run_case(case, settings)
