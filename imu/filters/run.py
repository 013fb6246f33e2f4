"""Run registered attitude filters on one record: :func:`run_filters` builds one :class:`FilterInputs` (the
samples, the rest window's measurements, the gates' design and the caller's per-filter design parameters) and
every filter of :mod:`imutherm.imu.filters.registry` reads what it needs from it.

Gate parameters of Liu et al.'s filter (defaults of :class:`GateConfig`), chosen from the physics of the
flight profile, not fitted to one run:

* ``xi_a = 3.7e-4 m/s^2``: the |f| error of a horizontal acceleration that tilts the apparent vertical by 0.5°
  (``g (1/cos 0.5° - 1)``), half of the paper's 1° stable-flight budget.
* ``xi_w = 0.1 m/s^2``: centripetal / tangential error worth about 0.6° of tilt.
* ``L = 1146 m``: radius of a standard-rate (3 °/s) turn at the 60 m/s cruise speed.
* ``d``: the installation lever arm (the trajectory's, assumed known).
* ``kp = 0.3 1/s`` (3 s time constant: fast recovery after a manoeuvre, tilt noise from 3.5 mg accelerometer
  noise below 0.02°), ``ki = 0.003 1/s^2`` (gyro-bias loop, ~20 s), gate low-pass ``tau = 0.1 s``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from imutherm import InputError
from imutherm.imu.filters.common import lever_arm_accel
from imutherm.imu.filters.gate import rest_reference
from imutherm.imu.filters.gated import default_thresholds
from imutherm.imu.filters.registry import REGISTRY, FilterInputs, filter_names


@dataclass(frozen=True)
class GateConfig:
    """Design parameters of Liu et al.'s gated filter and the rest window (see the module docstring).

    xi_a [m/s^2], xi_w [m/s^2], L [m], kp [1/s], ki [1/s^2], tau [s], hold_s [s],
    init_s [s] steady initial window used for leveling, the bias, the |f| reference and the R(·) widening,
    recover_s [s] the gate's recovery time (see :mod:`imutherm.imu.filters.gated`), tau_acc [s] the
    inertial-frame low-pass of the accelerometer (VQF's tauAcc; 0: Liu et al. 2012's per-sample gate), kp_lp [1/s]
    the gated filter's kp in that mode (``ungated`` keeps kp: it is the plain seed update).
    """

    xi_a: float = 3.7e-4
    xi_w: float = 0.1
    L: float = 1146.0
    kp: float = 0.3
    ki: float = 0.003
    tau: float = 0.1
    hold_s: float = 0.0
    init_s: float = 8.0
    recover_s: float = 30.0
    tau_acc: float = 0.0
    kp_lp: float = 1.0


def filter_inputs(gyro, accel, dt: float, lever_arm, gate: GateConfig = GateConfig(), *, design=None, gnss=None,
                  lever_comp: bool = False, steps=None, gyro_sample: str = "point") -> FilterInputs:
    """The one record the filters read (:class:`~imutherm.imu.filters.registry.FilterInputs`), arguments as
    :func:`run_filters`: the rest window's |f| reference and gyro bias measured, the gates' thresholds set,
    the accelerometer's lever-arm term removed if ``lever_comp``."""
    init_s = gate.init_s
    g_ref, bias0 = rest_reference(gyro, accel, dt, init_s)
    accel_raw, aekf_lever = accel, lever_arm
    if lever_comp:
        accel = accel - lever_arm_accel(gyro, dt, lever_arm, bias0)
        aekf_lever = None
    th = default_thresholds(gyro, accel, dt, xi_a=gate.xi_a, xi_w=gate.xi_w, d=lever_arm, L=gate.L,
                            tau=gate.tau, init_s=init_s, g=g_ref, bias=bias0)
    return FilterInputs(gyro, accel, accel_raw, dt, init_s, gate=gate, thresholds=th, g_ref=g_ref,
                        design={} if design is None else dict(design), lever_arm=aekf_lever, gnss=gnss,
                        steps=steps, gyro_sample=gyro_sample)


def run_filters(gyro, accel, dt: float, lever_arm, gate: GateConfig = GateConfig(), *, names=None, params=None,
                design=None, gnss=None, lever_comp: bool = False, settings=None, steps=None,
                gyro_sample: str = "point"):
    """Run the named filters on one record; returns ({name: AttitudeEstimate}, the gates' GateThresholds).

    gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s], lever_arm (3,) [m]. The first ``gate.init_s`` [s]
    must be at rest: the gyro bias, the |f| reference of the gates (the accelerometer's own rest reading,
    not nominal g) and the gates' noise widening are measured there (:func:`rest_reference`,
    :func:`~imutherm.imu.filters.gravity_kf.kf_params_from_rest`).
    ``names``: registered filters (:mod:`imutherm.imu.filters.registry`; None: every one that applies, those
    needing GNSS fixes only with ``gnss``); ``params`` {name: its params object, the registry's ``params_cls``}
    replaces what the filter would run with; ``design`` {name: params object} is the design a filter's
    default starts from (``kf``: the design KFParams, to which its runner adds the rest-window levels;
    ``fusion``: FusionParams, ``gyroscope_range`` the sensor's full scale [deg/s], None or 0: not declared).
    ``gnss`` (:class:`imutherm.imu.gnss.GnssVelocity`) feeds ``aekf_gnss``, which needs it.
    ``aekf`` removes the accelerometer's lever-arm term itself; ``lever_comp=True`` removes it
    (:func:`imutherm.imu.filters.common.lever_arm_accel`) for every gravity-referenced filter (all but
    ``aekf_gnss``), so that they are compared on the same information.
    ``settings`` {name: {field: value}} (the tuned settings, :mod:`imutherm.studies.attitude.filter_settings`) replaces
    fields of what each filter runs with (``params[name]``, else its registry default on this record:
    ``gated`` / ``ungated`` their GatedParams after the rest window set the thresholds, ``kf`` its KFParams
    before the rest-window levels are added).
    ``steps`` (N,) [s]: the true step ending at each sample of an irregular record (None: ``dt`` throughout);
    the filters whose registry entry says ``varying_dt`` integrate over it, the others (VQF) run at ``dt``.
    ``gyro_sample`` ('point' | 'interval', :data:`imutherm.imu.filters.common.GYRO_SAMPLES`): what a gyro sample
    is (the simulated sensor's: 'point'; a recorded log's: 'interval'), passed to our filters.

    Examples
    --------
    A turntable swing of ±80° in roll (10 s at rest first), an uncompensated unit at 25 °C, three filters;
    the roll and pitch RMS errors [°]:

    >>> import numpy as np
    >>> from imutherm.imu.motion import make_profile
    >>> from imutherm.imu.sensor_model import draw_unit, simulate_imu
    >>> from imutherm.imu.filters.run import run_filters
    >>> traj = make_profile("swing", duration=60.0, rate_hz=100.0)
    >>> unit = draw_unit("adis16355", np.random.default_rng(0))
    >>> raw = simulate_imu(unit, traj.t, traj.omega_b, traj.f_b, np.full((traj.t.size, 6), 25.0),
    ...                    np.random.default_rng(1))
    >>> estimates, _ = run_filters(raw.gyro, raw.accel, 0.01, traj.lever_arm, names=("gated", "kf", "vqf"))
    >>> for name, e in estimates.items():
    ...     rms = [np.degrees(np.sqrt(np.mean((a - b) ** 2))) for a, b in ((e.roll, traj.roll), (e.pitch, traj.pitch))]
    ...     print(f"{name:5s} roll {rms[0]:.2f} pitch {rms[1]:.2f}")
    gated roll 0.67 pitch 0.49
    kf    roll 1.18 pitch 0.41
    vqf   roll 0.65 pitch 0.59
    """
    params = {} if params is None else dict(params)
    settings = {} if settings is None else settings
    names = filter_names(gnss=gnss is not None) if names is None else tuple(names)
    x = filter_inputs(gyro, accel, dt, lever_arm, gate, design=design, gnss=gnss, lever_comp=lever_comp,
                      steps=steps, gyro_sample=gyro_sample)
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise InputError(f"filters: {unknown} unknown; valid: {', '.join(REGISTRY)}")
    if gnss is None and any(REGISTRY[n].needs_gnss for n in names):
        raise InputError("filter aekf_gnss: needs GNSS velocity fixes (gnss=...); valid: run it from the attitude "
                         "study, which simulates them")
    for n, vals in settings.items():
        if n in names:
            params[n] = replace(params.get(n) or REGISTRY[n].params(x), **vals)
    return {n: REGISTRY[n].run(x, params.get(n)) for n in names}, x.thresholds
