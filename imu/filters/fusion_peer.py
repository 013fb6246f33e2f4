"""The peer: x-io Fusion (``imufusion``) AHRS at its documented recommended settings.

Settings (Fusion README, "Algorithm settings"): gain 0.5 ("appropriate for
most applications"), acceleration rejection 10°, recovery trigger period 5 s
(in imufusion 1.3.3 the setting is ``rejection_timeout`` [s] with
``sample_rate`` [Hz]), gyroscope range = the declared sensor's range [°/s]
(:func:`gyro_range_of_grade` on simulated records, ``--gyro-range`` on a log; None, not declared: 0, the
library's over-range recovery off. Never the data's peak: a record peaking at 124 °/s got a 125 °/s range
that way and 1610 samples of over-range recovery); no magnetometer → ``update_no_magnetometer``. Gyroscope in °/s and
accelerometer in g as the library expects.

Frames: the library is run in its default North-West-Up convention with the
body axes converted FRD → FLU (``[x, -y, -z]``), so that a resting level
sensor reads +1 g on z, the usage of the library's examples. (Its NED mode
with our FRD specific force converged upside down in a check, so we do not
rely on it.) The gravity direction is converted back to our FRD body axes.

The README says the gyroscope offset-correction algorithm "should be used in
conjunction with the AHRS algorithm"; every entry point (:func:`run_fusion`,
:class:`FusionPeer`, :func:`fusion_step`) therefore passes the gyros through
``imufusion.Bias`` (its defaults: 3 °/s stationary threshold, 3 s stationary
period) first, unless ``FusionParams.use_bias=False``.

The library keeps its own state in C; the thin class :class:`FusionPeer`
wraps one ``Ahrs`` (and one ``Bias`` when ``use_bias``) and
:func:`fusion_step` is the procedural step on them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import imufusion
import numpy as np

from imutherm.imu.filters.registry import FilterSpec, Tuned, register
from imutherm.imu.attitude_math import G0, gravity_dir_body

_FLU = np.array([1.0, -1.0, -1.0])  # FRD <-> FLU axis flip


def _down_frd(q_flu) -> np.ndarray:
    """Gravity (down) direction in FRD body axes from quaternion(s) FLU body → NWU [-]."""
    up = gravity_dir_body(q_flu)  # NWU z (up) in FLU body axes
    return up * np.array([-1.0, 1.0, 1.0])
from imutherm.imu.filters.common import AttitudeEstimate, check_samples, estimate_from_gravity, sample_steps


@dataclass(frozen=True)
class FusionParams:
    """Recommended imufusion settings.

    gain [-] 0.5; acceleration_rejection [deg] 10; rejection_timeout [s] 5;
    gyroscope_range [deg/s] the declared sensor's full scale (0 or None, not declared: the over-range
    recovery off);
    use_bias : run the library's gyroscope offset correction (``imufusion.Bias``) first.
    """

    gain: float = 0.5
    acceleration_rejection: float = 10.0
    rejection_timeout: float = 5.0
    gyroscope_range: float | None = None
    use_bias: bool = True


#: common MEMS gyro full scales [deg/s] (ADXRS/ADIS 300, BMI/ICM/LSM 125-2000, ADIS16488 450)
GYRO_FULL_SCALES_DPS = (125.0, 250.0, 300.0, 450.0, 500.0, 1000.0, 2000.0, 4000.0)


def gyro_range_of_grade(grade) -> float:
    """The fusion peer's gyroscope range [deg/s] of a sensor grade (name or
    :class:`~imutherm.imu.sensor_model.SensorGrade`): its stated full scale (``full_scale_dps`` in
    :mod:`imutherm.imu.grades`; 0 where none is stated: over-range recovery off)."""
    from imutherm.imu.sensor_model import load_grade

    return float(np.degrees(load_grade(grade).gyro.full_scale))


def fusion_params_of_grade(grade, **settings) -> FusionParams:
    """:class:`FusionParams` (its recommended settings, ``settings`` overriding them) with the gyroscope range of
    a sensor grade (:func:`gyro_range_of_grade`): how every simulated record gives the peer its range."""
    return FusionParams(**{"gyroscope_range": gyro_range_of_grade(grade), **settings})


def looks_saturated(gyro, margin: float = 0.05) -> float | None:
    """The common full scale [deg/s] (:data:`GYRO_FULL_SCALES_DPS`) a record (N,3) [rad/s] looks clipped at,
    else None: on some axis the largest |rate| is within ``margin`` of that full scale and is reached, to the
    last digit, on at least 3 separate stretches of samples (a clipped sensor repeats its end code at every
    peak; a smooth peak, even held by sample-and-hold repeats, reaches its maximum once)."""
    x = np.degrees(np.abs(np.asarray(gyro, float)))
    for j in range(x.shape[1] if x.ndim == 2 else 0):
        a = x[:, j]
        m = float(np.max(a)) if a.size else 0.0
        top = a >= m * (1.0 - 1e-9)
        runs = int(top[0]) + int(np.sum(top[1:] & ~top[:-1]))
        if runs < 3:
            continue
        for fs in GYRO_FULL_SCALES_DPS:
            if abs(m - fs) <= margin * fs:
                return fs
    return None


def fusion_range_info(fusion: FusionParams | None, gyro) -> dict:
    """What the peer was told of the gyro range on a log: ``gyroscope_range_dps`` [deg/s] (0: not declared, its
    over-range recovery off), ``source`` and ``looks_saturated_at_dps`` (the common full scale the log's peak
    sits at, :func:`looks_saturated`, else None); gyro (N,3) [rad/s]."""
    r = None if fusion is None else fusion.gyroscope_range
    return {"gyroscope_range_dps": float(r or 0.0),
            "source": "--gyro-range" if r else "not declared (--gyro-range): over-range recovery off",
            "looks_saturated_at_dps": looks_saturated(gyro)}


def make_ahrs(dt: float, params: FusionParams) -> imufusion.Ahrs:
    """A configured ``imufusion.Ahrs`` for sample period ``dt`` [s]."""
    rng = 0.0 if params.gyroscope_range is None else float(params.gyroscope_range)
    if not (np.isfinite(rng) and rng >= 0):
        from imutherm import InputError
        raise InputError(f"FusionParams.gyroscope_range={params.gyroscope_range!r}; valid: the sensor's full "
                         "scale [deg/s] > 0, or 0 / None (not declared: over-range recovery off)")
    ahrs = imufusion.Ahrs()
    ahrs.set_settings(imufusion.AhrsSettings(
        sample_rate=1.0 / dt, convention=imufusion.CONVENTION_NWU, gain=params.gain,
        gyroscope_range=rng, acceleration_rejection=params.acceleration_rejection,
        magnetic_rejection=10.0, rejection_timeout=params.rejection_timeout))
    ahrs.set_sample_period(dt)
    return ahrs


def make_bias(dt: float, params: FusionParams) -> imufusion.Bias | None:
    """The gyroscope offset correction (``imufusion.Bias``, its default thresholds) for sample period
    ``dt`` [s], or None when ``params.use_bias`` is False."""
    if not params.use_bias:
        return None
    bias = imufusion.Bias()
    bias.set_settings(imufusion.BiasSettings(sample_rate=1.0 / dt))
    return bias


def fusion_step(ahrs: imufusion.Ahrs, gyro, accel, bias: imufusion.Bias | None = None) -> np.ndarray:
    """Feed one FRD sample (gyro (3,) [rad/s], accel (3,) [m/s^2]) to ``ahrs``.

    ``bias`` : the ``imufusion.Bias`` of :func:`make_bias` (None: no offset correction); when given, the
    gyro sample [°/s, FLU] passes through it first, as in :func:`run_fusion`.
    Returns the gravity direction (3,) [-] in FRD body axes after the update.
    """
    gd = np.degrees(np.asarray(gyro, float)) * _FLU
    if bias is not None:
        gd = bias.update(gd)
    ahrs.update_no_magnetometer(gd, np.asarray(accel, float) * (_FLU / G0))
    return _down_frd(np.asarray(ahrs.get_quaternion(), float))


class FusionPeer:
    """Thin class over one imufusion ``Ahrs`` and, if ``params.use_bias``, one ``Bias`` (dt [s],
    params : FusionParams); same result as :func:`run_fusion` with the same params."""

    name = "fusion"

    def __init__(self, dt: float, params: FusionParams = FusionParams()):
        self.ahrs = make_ahrs(dt, params)
        self.bias = make_bias(dt, params)

    def update(self, gyro, accel, dt: float | None = None) -> np.ndarray:
        """Process one sample (gyro [rad/s], accel [m/s^2], FRD); returns the gravity direction (3,) [-]."""
        return fusion_step(self.ahrs, gyro, accel, self.bias)

    @property
    def gravity(self) -> np.ndarray:
        """(3,) [-] gravity direction in body axes."""
        return _down_frd(np.asarray(self.ahrs.get_quaternion(), float))


def run_fusion(gyro, accel, dt: float, params: FusionParams = FusionParams(), *, steps=None) -> AttitudeEstimate:
    """Run the peer over a record; gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s]; steps (N,) [s] the true
    step ending at each sample of an irregular record (None: ``dt``), set as the AHRS's sample period before
    each update (its bias stage and timers keep ``dt``)."""
    gyro, accel = check_samples(gyro, accel, dt)
    dts = None if steps is None else sample_steps(steps, len(gyro), dt).tolist()
    t0 = time.perf_counter()
    ahrs = make_ahrs(dt, params)
    # the library works in float32 and casts what it is given: rows already float32 (the same rounding, done once
    # for the record) cost it ~160 ns an update instead of ~570 ns, and the Bias ~110 instead of ~290
    gd = np.ascontiguousarray(np.degrees(gyro) * _FLU, dtype=np.float32)
    ag = np.ascontiguousarray(accel * (_FLU / G0), dtype=np.float32)
    upd, getq, st = ahrs.update_no_magnetometer, ahrs.get_quaternion, ahrs.get_internal_states
    bias = make_bias(dt, params)
    period = ahrs.set_sample_period
    q, ignored = [], []   # lists, not rows of an array: this loop is the peer's cost (~0.5 us per sample)
    qa, ia = q.append, ignored.append
    rows = zip(list(gd), list(ag))
    if bias is not None and dts is None:   # the study's records: the loop with nothing else in it
        bupd = bias.update
        for g, a in rows:
            upd(bupd(g), a)
            qa(getq())
            ia(st().accelerometer_ignored)
    else:
        for k, (g, a) in enumerate(rows):
            if dts is not None:
                period(dts[k])
            upd(g if bias is None else bias.update(g), a)
            qa(getq())
            ia(st().accelerometer_ignored)
    return estimate_from_gravity("fusion", _down_frd(np.array(q).reshape(-1, 4)), ~np.array(ignored, bool),
                                 time.perf_counter() - t0)


# --------------------------------------------------------------------------- the registry's entry

def fusion_design(x) -> FusionParams:
    """``fusion``'s params on the record ``x`` (FilterInputs): ``x.design['fusion']`` (the sensor's declared
    gyro range), else the defaults."""
    return x.design.get("fusion") or FusionParams()


register(FilterSpec("fusion", lambda x, p: run_fusion(x.gyro, x.accel, x.dt, p or fusion_design(x), steps=x.steps),
                    FusionParams, "peer", "x-io Fusion (imufusion) README recommended settings", "tab:red",
                    base=fusion_design, groups={"study", "varying_dt", "gyro_range", "real_tuned"}, linestyle="-.",
                    rank=40,
                    tuning=(Tuned("gain", 3.16e-3, 1.0, (1e-4, 10.0), "gain [-] of x-io Fusion"),
                            Tuned("rejection_timeout", 3.16, 1000.0, (0.1, 1e4), "acceleration-rejection timeout "
                                                                                 "[s]"))))
