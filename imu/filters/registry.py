"""One registry of the attitude filters: each is declared once, and the study, the attitude command (profiles
and logs), the benchmarks and the plots read it.

A :class:`FilterSpec` holds the name, the runner, the parameter class (its defaults, each with its source in
that class's docstring), the source of the design, the plot colour and whether it needs GNSS fixes. The
runner takes a :class:`FilterInputs` (the samples and the settings the study derived from the rest window)
and the filter's own parameters (None: its defaults) and returns an
:class:`~imutherm.imu.filters.common.AttitudeEstimate`. :func:`register` adds one (a new filter appears in
``imutherm attitude --filters``, in :func:`imutherm.studies.attitude_study.run_filters` and in the plots).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from imutherm import InputError


@dataclass(frozen=True)
class FilterInputs:
    """What a runner gets: gyro (N,3) [rad/s], accel (N,3) [m/s^2] (lever-arm compensated if asked),
    accel_raw (N,3) [m/s^2] as measured, dt [s], init_s [s] rest window, gated (GatedParams: thresholds and gains
    from the rest window), kf (KFParams from the rest window), fusion (FusionParams), lever_arm (3,) [m] or None
    (the aekf's own lever-arm correction), gnss (GnssVelocity or None), ungated (GatedParams of the ungated
    baseline; None: ``gated``'s)."""

    gyro: np.ndarray = field(repr=False)
    accel: np.ndarray = field(repr=False)
    accel_raw: np.ndarray = field(repr=False)
    dt: float
    init_s: float
    gated: object
    kf: object
    fusion: object
    lever_arm: tuple | None = None
    gnss: object = None
    ungated: object = None


@dataclass(frozen=True)
class FilterSpec:
    """name; run(inputs, params) -> AttitudeEstimate; params_cls (None: settings come from FilterInputs);
    kind 'ours' | 'peer'; source (design / defaults); color (matplotlib); needs_gnss."""

    name: str
    run: Callable = field(repr=False)
    params_cls: type | None
    kind: str
    source: str
    color: str
    needs_gnss: bool = False


REGISTRY: dict[str, FilterSpec] = {}


def register(spec: FilterSpec) -> FilterSpec:
    """Add (or replace) a filter; returns it."""
    if not spec.name.isidentifier():
        raise InputError(f"filter name {spec.name!r} is invalid; valid: letters, digits, underscores")
    REGISTRY[spec.name] = spec
    return spec


def unregister(name: str) -> None:
    """Remove a filter (tests)."""
    REGISTRY.pop(name, None)


def filter_names(*, gnss: bool = True, kind: str | None = None) -> tuple:
    """Registered names in registration order; ``gnss=False`` leaves out those that need GNSS fixes."""
    return tuple(n for n, s in REGISTRY.items() if (gnss or not s.needs_gnss) and (kind is None or s.kind == kind))


def color(name: str):
    """Plot colour of a filter (None if it is not registered)."""
    s = REGISTRY.get(name)
    return None if s is None else s.color


def parse_filters(text: str | None, *, gnss: bool = True) -> tuple:
    """``--filters a,b,...`` (None or 'all': every registered filter that applies); refused with the valid
    names if one is unknown or needs GNSS where there is none."""
    valid = filter_names(gnss=gnss)
    if text is None or text.strip() == "all":
        return valid
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    bad = [n for n in names if n not in valid]
    if bad or not names:
        why = "" if gnss else " (a recorded log has no GNSS fixes)"
        what = ", ".join(bad) if bad else repr(text)
        raise InputError(f"--filters: {what} unknown or not applicable{why}; valid: "
                         f"{', '.join(valid)} or all")
    return names


def _register_builtin() -> None:
    from imutherm.imu.filters.aekf import AEKFParams, run_aekf
    from imutherm.imu.filters.fusion_peer import FusionParams, run_fusion
    from imutherm.imu.filters.gated import run_gated, run_ungated
    from imutherm.imu.filters.gravity_kf import run_kf
    from imutherm.imu.filters.peers import (EKFParams, MadgwickParams, MahonyParams, VQFParams, run_ekf,
                                            run_madgwick, run_mahony, run_vqf)

    def ungated(x, p):
        return run_ungated(x.gyro, x.accel, x.dt, p or x.ungated or x.gated, init_s=x.init_s)

    specs = [
        FilterSpec("gated", lambda x, p: run_gated(x.gyro, x.accel, x.dt, p or x.gated, init_s=x.init_s), None,
                   "ours", "Liu et al. 2012 gated strapdown (PAPER.md §3.2); GateConfig", "tab:blue"),
        FilterSpec("kf", lambda x, p: run_kf(x.gyro, x.accel, x.dt, p or x.kf, init_s=x.init_s), None, "ours",
                   "the horizontal-attitude KF paper's gravity-direction KF; KFParams", "tab:green"),
        FilterSpec("ungated", ungated, None, "ours", "Liu et al. 2012 update with the gate always open (baseline)",
                   "tab:gray"),
        FilterSpec("fusion", lambda x, p: run_fusion(x.gyro, x.accel, x.dt, p or x.fusion), FusionParams, "peer",
                   "x-io Fusion (imufusion) README recommended settings", "tab:red"),
        FilterSpec("aekf", lambda x, p: run_aekf(x.gyro, x.accel, x.dt, p or AEKFParams(), init_s=x.init_s,
                                                 lever_arm=x.lever_arm), AEKFParams, "ours",
                   "Wang et al.'s adaptive EKF (Sage-Husa R, ALS Q); AEKFParams", "tab:purple"),
        FilterSpec("aekf_gnss", lambda x, p: run_aekf(x.gyro, x.accel_raw, x.dt, p or AEKFParams(), gnss=x.gnss,
                                                      init_s=x.init_s), AEKFParams, "ours",
                   "Wang et al.'s adaptive EKF with GNSS velocity", "tab:brown", needs_gnss=True),
        FilterSpec("vqf", lambda x, p: run_vqf(x.gyro, x.accel, x.dt, p or VQFParams(), init_s=x.init_s), VQFParams,
                   "peer", "VQF, Laidig & Seel, Information Fusion 91, 2023 (vqf package defaults)", "black"),
        FilterSpec("madgwick", lambda x, p: run_madgwick(x.gyro, x.accel, x.dt, p or MadgwickParams(),
                                                         init_s=x.init_s), MadgwickParams, "peer",
                   "ahrs Madgwick defaults", "tab:orange"),
        FilterSpec("mahony", lambda x, p: run_mahony(x.gyro, x.accel, x.dt, p or MahonyParams(), init_s=x.init_s),
                   MahonyParams, "peer",
                   "ahrs Mahony defaults (k_P 1.0, k_I 0.3); recorded logs: studies.recorded.PLATFORM_MAHONY",
                   "tab:pink"),
        FilterSpec("ekf", lambda x, p: run_ekf(x.gyro, x.accel, x.dt, p or EKFParams(), init_s=x.init_s), EKFParams,
                   "peer", "ahrs EKF defaults", "tab:olive"),
    ]
    for s in specs:
        register(s)


_register_builtin()
