"""One registry of the attitude filters: each is declared once, and the study, the attitude command (profiles
and logs), the benchmarks and the plots read it.

A :class:`FilterSpec` holds the name, the runner, the parameter class (its defaults, each with its source in
that class's docstring), the source of the design, the plot colour, whether it needs GNSS fixes, its tuning
axes and the runs it belongs to (``in_study``: the end-to-end study's answer; ``in_sweep``: a sweep case's lean
IMU side). The runner takes a :class:`FilterInputs` (the samples and the settings the study derived from the
rest window) and the filter's own parameters (None: its defaults, or what ``base`` derives from the inputs)
and returns an :class:`~imutherm.imu.filters.common.AttitudeEstimate`. :func:`register` adds one: a new filter
appears in ``imutherm attitude --filters``, in :func:`imutherm.studies.attitude_study.run_filters`, in the
plots, in the tuning procedure (:mod:`imutherm.studies.filter_tuning`) if it declares axes, and in the study
(:class:`imutherm.studies.end_to_end.StudyConfig`, ``imutherm compare``) if it says ``in_study``. No other
module lists filters by name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from imutherm import InputError


@dataclass(frozen=True)
class FilterInputs:
    """What a runner gets: gyro (N,3) [rad/s], accel (N,3) [m/s^2] (lever-arm compensated if asked),
    accel_raw (N,3) [m/s^2] as measured, dt [s], init_s [s] rest window, gated (GatedParams: thresholds and gains
    from the rest window), kf (KFParams as designed: the ``kf`` runner adds the rest window's levels,
    :func:`~imutherm.imu.filters.gravity_kf.kf_params_from_rest`), fusion (FusionParams), lever_arm (3,) [m] or
    None (the aekf's own lever-arm correction), gnss (GnssVelocity or None), ungated (GatedParams of the ungated
    baseline; None: ``gated``'s), steps ((N,) [s] the true step ending at each sample of an irregular record, or
    None: ``dt`` throughout; a runner that takes it passes it on, :attr:`FilterSpec.varying_dt`), gyro_sample
    ('point' | 'interval', :data:`~imutherm.imu.filters.common.GYRO_SAMPLES`: what a gyro sample is; ours take it
    into their params, the peers always integrate ω_k over the step ending at k)."""

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
    steps: np.ndarray | None = field(default=None, repr=False)
    gyro_sample: str = "point"


#: the study's tuning ladder: every tuned value is 10^(k / TUNING_STEPS_PER_DECADE) for an integer k, the same
#: step (x3.16) for every parameter of every filter, ours and the peers
TUNING_STEPS_PER_DECADE = 2


@dataclass(frozen=True)
class Tuned:
    """One axis of the study's tuning grid (:mod:`benchmarks.tune_study_filters`).

    field : the parameter tuned; lo, hi : the span tried first (rounded out to the ladder,
    :data:`TUNING_STEPS_PER_DECADE`), extended a step at a time while the best lies on its edge, up to
    ``bounds`` (the physically sensible range); off : values tried besides the ladder (e.g. 0: a seed's own mode);
    derived : {field: function of this one} moved along with it (a gain pair kept at a published ratio);
    why : what the axis spans, in words.
    """

    field: str
    lo: float
    hi: float
    bounds: tuple
    why: str
    off: tuple = ()
    derived: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        if not (0 < self.bounds[0] <= self.lo <= self.hi <= self.bounds[1]):
            raise InputError(f"tuning axis {self.field}: need 0 < bounds[0] <= lo <= hi <= bounds[1], got "
                             f"lo {self.lo}, hi {self.hi}, bounds {self.bounds}")

    def rung(self, value: float) -> int:
        """The ladder index k of ``value`` (nearest)."""
        return int(round(TUNING_STEPS_PER_DECADE * np.log10(value)))

    @staticmethod
    def value(k: int) -> float:
        """The ladder's k-th value, 10^(k / steps per decade), to 3 significant figures."""
        return float(f"{10.0 ** (k / TUNING_STEPS_PER_DECADE):.3g}")

    def point(self, v: float) -> dict:
        """{field: v, derived fields: their values}."""
        return {self.field: v, **{k: f(v) for k, f in self.derived.items()}}

    def start(self) -> list:
        """The first span's ladder indices, lo..hi rounded outwards."""
        a = int(np.floor(TUNING_STEPS_PER_DECADE * np.log10(self.lo) + 1e-3))
        b = int(np.ceil(TUNING_STEPS_PER_DECADE * np.log10(self.hi) - 1e-3))
        return list(range(a, b + 1))

    def within(self, k: int) -> bool:
        return self.bounds[0] * (1 - 1e-9) <= self.value(k) <= self.bounds[1] * (1 + 1e-9)


@dataclass(frozen=True)
class FilterSpec:
    """One filter, declared once.

    name; run(inputs, params) -> AttitudeEstimate (params None: ``base(inputs)`` or the class defaults);
    params_cls : the dataclass whose fields its settings name (tuned values, ``--platform`` settings; None: it
    takes none); kind 'ours' | 'peer'; source (design / defaults); color, linestyle (matplotlib); needs_gnss;
    tuning : the axes the tuning procedure searches (:class:`Tuned`; empty: not tuned);
    base : inputs -> the params object the runner uses by default, when it is derived from the record (the
    gates' thresholds from the rest window, the sensor's gyro range); None: ``params_cls()``;
    in_study : shown in the end-to-end study's answer (``imutherm compare``, :func:`study_filters`);
    in_sweep : run in a sweep case's lean IMU side (:func:`sweep_filters`);
    varying_dt : the runner integrates over the true per-sample steps ``inputs.steps`` of an irregular record
    (False: it takes one sample period, ``dt``, the median step);
    real_tuned : tuned on the real development files (:mod:`imutherm.studies.real_tuning`, :func:`real_filters`)
    for the recorded-log settings; False where the procedure's guard (no file worse than the library defaults)
    would keep defaults that are themselves a trap on real motion.
    """

    name: str
    run: Callable = field(repr=False)
    params_cls: type | None
    kind: str
    source: str
    color: str
    needs_gnss: bool = False
    tuning: tuple = ()
    base: Callable | None = field(default=None, repr=False)
    in_study: bool = False
    in_sweep: bool = False
    varying_dt: bool = False
    linestyle: object = "-"
    real_tuned: bool = True

    def params(self, inputs: "FilterInputs"):
        """The params object the filter runs with by default on ``inputs`` (None: it takes none)."""
        if self.base is not None:
            return self.base(inputs)
        return None if self.params_cls is None else self.params_cls()


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
    """Registered names in registration order; ``gnss=False`` leaves out those that need GNSS fixes; ``kind``
    'ours' | 'peer' only those."""
    return tuple(n for n, s in REGISTRY.items() if (gnss or not s.needs_gnss) and (kind is None or s.kind == kind))


def study_filters() -> tuple:
    """The filters of the end-to-end study's answer (``in_study``; none that needs GNSS), registration order."""
    return tuple(n for n, s in REGISTRY.items() if s.in_study and not s.needs_gnss)


def sweep_filters() -> tuple:
    """The filters of a sweep case's lean IMU side (``in_sweep``), registration order."""
    return tuple(n for n, s in REGISTRY.items() if s.in_sweep and not s.needs_gnss)


def tuned_filters() -> tuple:
    """The filters that declare tuning axes (and need no GNSS fixes, which the tuning records do not carry)."""
    return tuple(n for n, s in REGISTRY.items() if s.tuning and not s.needs_gnss)


def real_filters() -> tuple:
    """The filters tuned on the real development files (:func:`tuned_filters` whose entry says ``real_tuned``)."""
    return tuple(n for n in tuned_filters() if REGISTRY[n].real_tuned)


def color(name: str):
    """Plot colour of a filter (None if it is not registered)."""
    s = REGISTRY.get(name)
    return None if s is None else s.color


def linestyle(name: str):
    """Plot line style of a filter ("-" if it is not registered)."""
    s = REGISTRY.get(name)
    return "-" if s is None else s.linestyle


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
    from imutherm.imu.filters.gated import GatedParams, run_gated, run_ungated
    from imutherm.imu.filters.gravity_kf import KFParams, kf_params_from_rest, run_kf
    from imutherm.imu.filters.peers import (EKFParams, MadgwickParams, MahonyParams, VQFParams, run_ekf,
                                            run_madgwick, run_mahony, run_vqf)

    def gs(p, x):  # the record's gyro sample convention into our filters' params
        return replace(p, gyro_sample=x.gyro_sample)

    def gated(x, p):
        return run_gated(x.gyro, x.accel, x.dt, gs(p or x.gated, x), init_s=x.init_s, steps=x.steps)

    def kf(x, p):  # the design KFParams plus the rest window's |f| reference and gate level
        return run_kf(x.gyro, x.accel, x.dt, kf_params_from_rest(x.gyro, x.accel, x.dt, x.init_s, gs(p or x.kf, x)),
                      init_s=x.init_s, steps=x.steps)

    def ungated(x, p):
        return run_ungated(x.gyro, x.accel, x.dt, gs(p or x.ungated or x.gated, x), init_s=x.init_s, steps=x.steps)

    def aekf(x, p):
        return run_aekf(x.gyro, x.accel, x.dt, gs(p or AEKFParams(), x), init_s=x.init_s, lever_arm=x.lever_arm,
                        steps=x.steps)

    def aekf_gnss(x, p):
        return run_aekf(x.gyro, x.accel_raw, x.dt, gs(p or AEKFParams(), x), gnss=x.gnss, init_s=x.init_s,
                        steps=x.steps)

    specs = [
        FilterSpec("gated", gated, GatedParams, "ours", "Liu et al. 2012 gated strapdown (PAPER.md §3.2); GateConfig",
                   "tab:blue", base=lambda x: x.gated, in_study=True, in_sweep=True, varying_dt=True,
                   tuning=(Tuned("tau_acc", 1.0, 31.6, (0.1, 1000.0), "tau_acc [s]; 0 = the seed's per-sample gate",
                                 off=(0.0,)),
                           Tuned("kp", 0.0316, 1.0, (1e-3, 10.0), "kp [1/s] the correction gain (kp_lp in the "
                                                                  "low-pass mode)"))),
        FilterSpec("kf", kf, KFParams, "ours", "the horizontal-attitude KF paper's gravity-direction KF; KFParams",
                   "tab:green", base=lambda x: x.kf, in_study=True, in_sweep=True, varying_dt=True, linestyle="--",
                   tuning=(Tuned("tau_acc", 1.0, 3.16, (0.1, 1000.0), "tau_acc [s]; 0 = the seed's window mean and "
                                                                      "gate 1", off=(0.0,)),
                           Tuned("q", 1e-7, 3.16e-4, (1e-10, 0.1), "q [rad^2/s] the process noise of the gravity "
                                                                   "direction"))),
        FilterSpec("ungated", ungated, GatedParams, "ours",
                   "Liu et al. 2012 update with the gate always open (baseline)", "tab:gray",
                   base=lambda x: x.ungated or x.gated, in_study=True, varying_dt=True, linestyle=":",
                   tuning=(Tuned("kp", 1e-3, 1.0, (1e-4, 10.0), "kp [1/s], ki [1/s^2] = kp^2 / 30 along the seed's "
                                                                "ratio (0.3, 0.003), the gate always open",
                                 derived={"ki": lambda kp: kp * kp / 30.0}),)),
        FilterSpec("fusion", lambda x, p: run_fusion(x.gyro, x.accel, x.dt, p or x.fusion, steps=x.steps),
                   FusionParams, "peer", "x-io Fusion (imufusion) README recommended settings", "tab:red",
                   base=lambda x: x.fusion, in_study=True, varying_dt=True, linestyle="-.",
                   tuning=(Tuned("gain", 3.16e-3, 1.0, (1e-4, 10.0), "gain [-] of x-io Fusion"),
                           Tuned("rejection_timeout", 3.16, 1000.0, (0.1, 1e4), "acceleration-rejection timeout "
                                                                                "[s]"))),
        FilterSpec("aekf", aekf, AEKFParams, "ours",
                   "Wang et al.'s adaptive EKF (Sage-Husa R, ALS Q); AEKFParams", "tab:purple", in_study=True,
                   varying_dt=True, linestyle=(0, (3, 1)),
                   tuning=(Tuned("tau_acc", 1.0, 1.0, (0.1, 100.0), "tau_acc [s]; 0 = the block mean", off=(0.0,)),
                           Tuned("memory_s", 1.0, 31.6, (0.1, 1000.0), "memory_s [s] the fading memory of the "
                                                                       "adaptation laws"))),
        FilterSpec("aekf_gnss", aekf_gnss, AEKFParams, "ours",
                   "Wang et al.'s adaptive EKF with GNSS velocity", "tab:brown", needs_gnss=True, varying_dt=True),
        FilterSpec("vqf", lambda x, p: run_vqf(x.gyro, x.accel, x.dt, p or VQFParams(), init_s=x.init_s), VQFParams,
                   "peer", "VQF, Laidig & Seel, Information Fusion 91, 2023 (vqf package defaults)", "black",
                   in_study=True, linestyle=(0, (5, 1, 1, 1, 1, 1)),
                   tuning=(Tuned("tauAcc", 1.0, 1000.0, (0.1, 1e5), "tauAcc [s], VQF's accelerometer low-pass time "
                                                                    "constant (its main tuning parameter)"),
                           Tuned("biasSigmaMotion", 0.0316, 1.0, (1e-3, 2.0),
                                 "biasSigmaMotion [deg/s], the converged uncertainty of VQF's motion bias update "
                                 "(package default 0.1), bounded at VQF's biasClip 2 deg/s, the largest bias it "
                                 "admits; inf = the update off (motionBiasEstEnabled false), its limit",
                                 off=(math.inf,)))),
        FilterSpec("madgwick", lambda x, p: run_madgwick(x.gyro, x.accel, x.dt, p or MadgwickParams(),
                                                         init_s=x.init_s, steps=x.steps), MadgwickParams, "peer",
                   "ahrs Madgwick defaults", "tab:orange", varying_dt=True,
                   tuning=(Tuned("gain", 3.16e-4, 0.1, (1e-5, 10.0), "gain [rad/s] (published default 0.033)"),)),
        FilterSpec("mahony", lambda x, p: run_mahony(x.gyro, x.accel, x.dt, p or MahonyParams(), init_s=x.init_s,
                                                     steps=x.steps), MahonyParams, "peer",
                   "ahrs Mahony defaults (k_P 1.0, k_I 0.3), a trap on real motion: every motion profile and "
                   "recorded-log platform runs its tuned setting (studies.recorded.platform_mahony); not tuned on "
                   "the real files, where the guard against its defaults keeps them (24 deg on BROAD trial 16)",
                   "tab:pink", varying_dt=True, real_tuned=False,
                   tuning=(Tuned("k_P", 3.16e-3, 1.0, (1e-4, 10.0), "k_P [1/s], k_I [1/s^2] = 0.3 k_P^2 (published "
                                                                   "default (1, 0.3))",
                                 derived={"k_I": lambda k: 0.3 * k * k}),)),
        FilterSpec("ekf", lambda x, p: run_ekf(x.gyro, x.accel, x.dt, p or EKFParams(), init_s=x.init_s,
                                               steps=x.steps), EKFParams,
                   "peer", "ahrs EKF defaults", "tab:olive", varying_dt=True,
                   tuning=(Tuned("var_acc", 0.316, 3.16e4, (1e-3, 1e7), "var_acc [-] of the unit gravity vector "
                                                                       "(published default 0.25)"),)),
    ]
    for s in specs:
        register(s)


_register_builtin()
