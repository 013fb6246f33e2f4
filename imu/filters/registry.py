"""One registry of the attitude filters: each is declared once, and the study, the attitude command (profiles
and logs), the benchmarks and the plots read it.

A :class:`FilterSpec` holds the name, the runner, the parameter class (its defaults, each with its source in that
class's docstring), the source of the design, the plot colour, whether it needs GNSS fixes, its tuning axes and the
groups it belongs to (:data:`GROUPS`: ``study``, the end-to-end study's answer; ``sweep``, a sweep case's lean IMU
side; ...; :func:`in_group`). The runner takes a :class:`FilterInputs` (the samples and the settings the study
derived from the rest window) and the filter's own parameters (None: its defaults, or what ``base`` derives from the
inputs) and returns an :class:`~imutherm.imu.filters.common.AttitudeEstimate`. :func:`register` adds one: a new
filter appears in ``imutherm attitude --filters``, in :func:`imutherm.imu.filters.run.run_filters`, in the plots, in
the tuning procedure (:mod:`imutherm.studies.attitude.filter_tuning`) if it declares axes, and in the study
(:class:`imutherm.studies.end_to_end.StudyConfig`, ``imutherm compare``) if its groups say ``study``. No other
module lists filters by name.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from imutherm import InputError


@dataclass(frozen=True)
class FilterInputs:
    """The one record every runner reads what it needs from (built by :func:`imutherm.imu.filters.run.filter_inputs`).

    gyro (N,3) [rad/s]; accel (N,3) [m/s^2] (lever-arm compensated if asked); accel_raw (N,3) [m/s^2] as
    measured; dt [s]; init_s [s] the rest window; gate (:class:`~imutherm.imu.filters.run.GateConfig`: the gates'
    design); thresholds (GateThresholds set from the rest window); g_ref [m/s^2] the accelerometer's |f| at rest;
    design {filter name: the design params object its default starts from, e.g. ``kf``'s KFParams before the rest
    window's levels, ``fusion``'s FusionParams with the sensor's gyro range}; lever_arm (3,) [m] or None (the
    aekf's own lever-arm correction); gnss (GnssVelocity or None); steps ((N,) [s] the true step ending at each
    sample of an irregular record, or None: ``dt`` throughout; a runner that takes it passes it on,
    the group ``varying_dt`` of :data:`GROUPS`); gyro_sample ('point' | 'interval',
    :data:`~imutherm.imu.filters.common.GYRO_SAMPLES`: what a gyro sample is; ours take it into their params,
    the peers always integrate ω_k over the step ending at k)."""

    gyro: np.ndarray = field(repr=False)
    accel: np.ndarray = field(repr=False)
    accel_raw: np.ndarray = field(repr=False)
    dt: float
    init_s: float
    gate: object = None
    thresholds: object = None
    g_ref: float | None = None
    design: dict = field(default_factory=dict)
    lever_arm: tuple | None = None
    gnss: object = None
    steps: np.ndarray | None = field(default=None, repr=False)
    gyro_sample: str = "point"

    def default(self, name: str):
        """The params object filter ``name`` runs with by default on this record (:meth:`FilterSpec.params`)."""
        if name not in REGISTRY:
            raise InputError(f"filter {name!r} unknown; valid: {', '.join(REGISTRY)}")
        return REGISTRY[name].params(self)


#: the study's tuning ladder: every tuned value is 10^(k / TUNING_STEPS_PER_DECADE) for an integer k, the same
#: step (x3.16) for every parameter of every filter, ours and the peers
TUNING_STEPS_PER_DECADE = 2


@dataclass(frozen=True)
class Tuned:
    """One axis of the study's tuning grid (:mod:`benchmarks.tune_study_filters`).

    field : the parameter tuned; lo, hi : the span tried first (rounded out to the ladder,
    :data:`TUNING_STEPS_PER_DECADE`), extended a step at a time while the best lies on its edge, up to
    ``bounds`` (the physically sensible range); off : values tried besides the ladder (e.g. 0: the source
    paper's own mode);
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


#: the groups a filter can belong to (:attr:`FilterSpec.groups`), each with what membership means
GROUPS = {
    "study": "shown in the end-to-end study's answer (imutherm compare, study_filters)",
    "sweep": "run in a sweep case's lean IMU side (sweep_filters)",
    "varying_dt": "the runner integrates over the true per-sample steps inputs.steps of an irregular record "
                  "(otherwise it takes one sample period, dt, the median step)",
    "real_tuned": "tuned on the real development files for the recorded-log settings (studies.attitude.real_tuning, "
                  "real_filters); left out where the procedure's guard (no file worse than the library defaults) "
                  "would keep defaults that are themselves a trap on real motion",
    "reference": "the peer each filter's real-motion figures are set against (the ratio column of the tables)",
    "platform_tuned": "its defaults are a trap on real motion, so each recorded-log platform runs its tuned "
                      "setting (studies.attitude.recorded.platform_setting)",
    "gyro_range": "it takes the sensor's declared gyro full scale (--gyro-range: its over-range recovery), and the "
                  "attitude commands say what it ran with",
}


@dataclass(frozen=True)
class FilterSpec:
    """One filter, declared once.

    name; run(inputs, params) -> AttitudeEstimate (params None: ``base(inputs)`` or the class defaults);
    params_cls : the dataclass whose fields its settings name (tuned values, ``--platform`` settings; None: it
    takes none); kind 'ours' | 'peer'; source (design / defaults); color, linestyle (matplotlib); needs_gnss;
    tuning : the axes the tuning procedure searches (:class:`Tuned`; empty: not tuned);
    base : inputs -> the params object the runner uses by default, when it is derived from the record (the
    gates' thresholds from the rest window, the sensor's gyro range); None: ``params_cls()``;
    groups : the runs and roles it belongs to, names of :data:`GROUPS` (a frozenset; any iterable of names is
    taken), queried by :func:`in_group`;
    rank : its place in the registry, the tables and the plots (lower first; ties in registration order).

    Each filter's spec is registered at the bottom of its own module (as meshio registers each format).
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
    groups: frozenset = frozenset()
    linestyle: object = "-"
    rank: int = 100

    def __post_init__(self):
        if isinstance(self.groups, str):
            raise InputError(f"filter {self.name!r}: groups must be a set of group names, got the string "
                             f"{self.groups!r}")
        object.__setattr__(self, "groups", frozenset(self.groups))

    def params(self, inputs: "FilterInputs"):
        """The params object the filter runs with by default on ``inputs`` (None: it takes none)."""
        if self.base is not None:
            return self.base(inputs)
        return None if self.params_cls is None else self.params_cls()


REGISTRY: dict[str, FilterSpec] = {}


def register(spec: FilterSpec) -> FilterSpec:
    """Add (or replace) a filter, in the registry's order by :attr:`FilterSpec.rank`; returns it."""
    if not spec.name.isidentifier():
        raise InputError(f"filter name {spec.name!r} is invalid; valid: letters, digits, underscores")
    unknown = sorted(spec.groups - set(GROUPS))
    if unknown:
        raise InputError(f"filter {spec.name!r}: group {', '.join(unknown)} unknown; valid: {', '.join(GROUPS)}")
    REGISTRY[spec.name] = spec
    ordered = sorted(REGISTRY.values(), key=lambda s: s.rank)  # stable: ties keep their registration order
    REGISTRY.clear()
    REGISTRY.update((s.name, s) for s in ordered)
    return spec


def unregister(name: str) -> None:
    """Remove a filter (tests)."""
    REGISTRY.pop(name, None)


def filter_names(*, gnss: bool = True, kind: str | None = None) -> tuple:
    """Registered names in registration order; ``gnss=False`` leaves out those that need GNSS fixes; ``kind``
    'ours' | 'peer' only those."""
    return tuple(n for n, s in REGISTRY.items() if (gnss or not s.needs_gnss) and (kind is None or s.kind == kind))


def in_group(group: str, names=None) -> tuple:
    """The registered filters of ``group`` (a name of :data:`GROUPS`), in registry order; or those of ``names``
    (in their order) that are in it."""
    if group not in GROUPS:
        raise InputError(f"filter group {group!r} unknown; valid: {', '.join(GROUPS)}")
    if names is not None:
        return tuple(n for n in names if n in REGISTRY and group in REGISTRY[n].groups)
    return tuple(n for n, s in REGISTRY.items() if group in s.groups)


def study_filters() -> tuple:
    """The filters of the end-to-end study's answer (group ``study``; none that needs GNSS), registry order."""
    return tuple(n for n in in_group("study") if not REGISTRY[n].needs_gnss)


def sweep_filters() -> tuple:
    """The filters of a sweep case's lean IMU side (group ``sweep``; none that needs GNSS), registry order."""
    return tuple(n for n in in_group("sweep") if not REGISTRY[n].needs_gnss)


def tuned_filters() -> tuple:
    """The filters that declare tuning axes (and need no GNSS fixes, which the tuning records do not carry)."""
    return tuple(n for n, s in REGISTRY.items() if s.tuning and not s.needs_gnss)


def real_filters() -> tuple:
    """The filters tuned on the real development files (:func:`tuned_filters` of the group ``real_tuned``)."""
    return in_group("real_tuned", tuned_filters())


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


def reference_filter() -> str | None:
    """The filter each filter's real-motion figures are set against (group ``reference``), or None."""
    return next(iter(in_group("reference")), None)


def platform_tuned_filters() -> tuple:
    """The filters each recorded-log platform runs at its tuned setting (group ``platform_tuned``)."""
    return in_group("platform_tuned")


def gyro_range_filters(names) -> tuple:
    """Those of ``names`` that take the sensor's declared gyro range (group ``gyro_range``)."""
    return in_group("gyro_range", names)
