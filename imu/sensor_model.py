"""Truth model of a six-sensor MEMS IMU (3 gyros, 3 accelerometers) with temperature effects.

Pure functions of arrays plus frozen dataclasses that bundle parameters
(pvlib style). Everything is SI inside (rad/s, m/s^2, s); temperatures are in
°C, as at every interface of the package.

Measurement model of one sensor triad (gyro shown; accelerometer alike)::

    u      = M0 @ x                       true input projected on the sensitive axes
                                           (M0 = I + misalignment, unit-specific)
    y_i    = (1 + s0_i + s_i(T_i) + a_i sign(u_i)/2) u_i + K2_i u_i^2      (a, K2: accel only)
             + b0_i + b_i(T_i) + p_i(T_i) + h_i dT_i/dt + (G f)_i         (G: gyro only)
             + noise_i
    y      = quantise(y, LSB)

``x`` is the true body rate [rad/s] (gyros) or the specific force [m/s^2]
(accelerometers); ``T_i`` the true die temperature of site i [°C].

* ``s_i(T)``, ``b_i(T)``: strongly nonlinear, unit-specific smooth curves (a
  cubic in x = (T - 25)/55 plus a smooth sine wiggle), zero at 25 °C, scaled so
  the peak over -40..70 °C equals the grade's amplitude times a unit factor
  drawn in 0.5..1.5 (Liu et al. 2012: units of one type differ strongly).
* ``p_i(T) = p0 + p1 x + p2 x^2``: the power-on-to-power-on component (a
  turn-on bias plus a small random change of the curve), drawn once per
  power-on (:class:`PowerOn`), larger for accelerometers than for gyros.
* ``h_i dT_i/dt``: thermal-gradient / hysteresis term, per °C/min of the true
  die temperature rate.
* Lin et al.'s dynamic terms: accelerometer scale-factor asymmetry ``a_i`` and
  quadratic coefficient ``K2_i``; gyro g-sensitivity ``G`` (3x3) [rad/s per m/s^2].
* Wang et al.'s high-rate roll coupling: the y and z gyros read ``c2 ω_x² + c3 ω_x³``
  more, ω_x the body roll rate (:func:`draw_roll_coupling`; sizes in the grade).
  Wang et al. shows the effect (a rolling projectile's non-rolling axes, figure 3)
  but gives no form or number; the form is the lowest-order nonlinear one
  (an even term, as a centrifugal change of the sense-mode stiffness would
  give, and an odd one beyond the linear misalignment, which the ordinary
  calibration already takes out).
* Noise from Allan parameters: white (ARW / VRW), bias instability as a
  first-order Gauss-Markov process, rate random walk; then quantisation.
  The grade's bias instability B is the datasheet figure, i.e. the floor of
  the Allan deviation. The Allan deviation of a first-order Gauss-Markov
  process of standard deviation sigma and correlation time Tc peaks at
  ``GM_ADEV_PEAK`` = 0.6174 sigma (at tau = 1.89 Tc), so the process is run
  with ``sigma = B / GM_ADEV_PEAK`` (~1.62 B) and its Allan floor equals B.

Each site's internal temperature sensor reports the die temperature through a
first-order lag ``tau`` (exact first-order-hold discretisation: exact for
piecewise-linear die temperature) plus a unit-specific offset, quantised to
the sensor LSB. Compensation uses this *reported* temperature.

Earth rotation is not modelled (the rig and the vehicle truth are the same
inertial rate); it is below the ADIS16355 noise.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np
from scipy.signal import lfilter

from imutherm import InputError
from imutherm.constants import STANDARD_GRAVITY as G0  # [m/s^2]
from imutherm.imu.grades import GRADES
from imutherm.site_table import SITES  # noqa: F401  (the site names, defined once; re-exported)

T_REF_C = 25.0  # [°C] room (reference) temperature of the curves
T_RANGE_C = (-40.0, 70.0)  # [°C] the paper's operating / calibrated range (Liu et al. 2012)
#: [°C] die temperatures the truth model accepts: the curves are scaled over T_RANGE_C and continue
#: smoothly (cubic + wiggle) beyond it; ADIS16355 / ADXRS150 datasheets rate operation to +85 °C and
#: storage to +125 °C; 105 °C leaves room for a hot scheme's sensor dies at 70 °C ambient (assumed limit)
T_MODEL_RANGE_C = (-55.0, 105.0)
_X_SCALE = 55.0  # [°C] normalisation of the curve argument x = (T - 25)/55
#: [-] peak Allan deviation of a first-order Gauss-Markov process divided by its standard deviation sigma.
#: Allan variance of exponentially correlated (Markov) noise, q = 2 sigma^2 / Tc (IEEE Std 952-1997 Annex C;
#: El-Sheimy, Hou, Niu, "Analysis and modeling of inertial sensors using Allan variance", IEEE Trans.
#: Instrum. Meas. 57(1), 2008): AVAR(T) = (q Tc^2 / T) [1 - Tc/(2T) (3 - 4 e^(-T/Tc) + e^(-2T/Tc))];
#: its maximum over T (at T = 1.893 Tc) is (0.6174 sigma)^2. Checked numerically in tests/test_imu_sensor.py.
GM_ADEV_PEAK = 0.6174

_DEG = np.pi / 180.0
_MG = G0 * 1e-3


# --------------------------------------------------------------------------- grades
@dataclass(frozen=True)
class SensorSpec:
    """Error and noise specification of one sensor type (gyro or accelerometer), SI.

    ``unit`` below is [rad/s] for gyros and [m/s^2] for accelerometers.

    Attributes
    ----------
    noise_density : float [unit/sqrt(Hz)]  white noise (ARW / VRW); rms per sample = density*sqrt(fs)
    bias_instability : float [unit]        bias instability B = Allan-deviation floor (datasheet in-run bias
                                           stability); the Gauss-Markov process has sigma = B / GM_ADEV_PEAK
    bias_corr_time_s : float [s]           Gauss-Markov correlation time
    rate_random_walk : float [unit/sqrt(s)] bias random walk
    lsb : float [unit]                     quantisation step (0 = none)
    initial_bias : float [unit]            1-sigma bias at 25 °C of a unit
    initial_sf : float [-]                 1-sigma scale-factor error at 25 °C
    misalignment : float [rad]             1-sigma of each off-diagonal misalignment element
    turn_on_bias : float [unit]            1-sigma power-on to power-on bias change
    bias_temp_amplitude : float [unit]     nominal peak of the bias-vs-temperature curve over -40..70 °C
    sf_temp_amplitude : float [-]          nominal peak of the scale-factor-vs-temperature curve
    power_on_curve_fraction : float [-]    power-on random change of the curve, fraction of its peak
    temp_rate_coeff : float [unit per °C/min] 1-sigma thermal-gradient (dT/dt) bias coefficient
    g_sensitivity : float [rad/s per m/s^2] 1-sigma gyro g-sensitivity element (gyro only)
    misalignment_tempco : float [rad/K]    1-sigma of each off-diagonal misalignment temperature coefficient
    asymmetry : float [-]                  1-sigma scale-factor asymmetry (accel only)
    k2 : float [1/(m/s^2)]                 1-sigma quadratic coefficient (accel only)
    roll_coupling : tuple [rad/s]          gyro only: 1-sigma error of the y and z gyros at roll rate
                                           ``roll_coupling_ref`` from the quadratic and the cubic coupling term
    roll_coupling_ref : float [rad/s]      roll rate at which ``roll_coupling`` is stated
    full_scale : float [unit]              gyro only: the measurement range (datasheet full scale; 0 = not
                                           stated); the fusion peer's gyroscope range, not a saturation of the model
    """

    noise_density: float
    bias_instability: float
    bias_corr_time_s: float
    rate_random_walk: float
    lsb: float
    initial_bias: float
    initial_sf: float
    misalignment: float
    turn_on_bias: float
    bias_temp_amplitude: float
    sf_temp_amplitude: float
    power_on_curve_fraction: float
    temp_rate_coeff: float
    g_sensitivity: float = 0.0
    misalignment_tempco: float = 0.0
    asymmetry: float = 0.0
    k2: float = 0.0
    roll_coupling: tuple = (0.0, 0.0)
    roll_coupling_ref: float = 1.0
    full_scale: float = 0.0


@dataclass(frozen=True)
class SensorGrade:
    """A named sensor grade (parameter set as data, see :mod:`imutherm.imu.grades`).

    Attributes
    ----------
    name : str
    description : str
    sources : tuple[str, ...]           provenance of the numbers
    sample_rate_hz : float [Hz]         nominal output rate
    temp_sensor_tau_s : float [s]       first-order lag of the internal temperature sensors
    temp_sensor_offset_std_C : float [°C] 1-sigma offset of each internal temperature sensor
    temp_sensor_lsb_C : float [°C]      quantisation of the reported temperature (0 = none)
    gyro : SensorSpec                   [rad/s units]
    accel : SensorSpec                  [m/s^2 units]
    """

    name: str
    description: str
    sources: tuple
    sample_rate_hz: float
    temp_sensor_tau_s: float
    temp_sensor_offset_std_C: float
    temp_sensor_lsb_C: float
    gyro: SensorSpec
    accel: SensorSpec


def _spec_from_dict(d: dict, kind: str) -> SensorSpec:
    """A grade table's gyro (deg/s units) or accelerometer (mg units) entry as a :class:`SensorSpec` in SI."""
    unit, u = ("dps", _DEG) if kind == "gyro" else ("mg", _MG)  # deg/s -> rad/s, mg -> m/s^2
    common = dict(
        noise_density=d[f"noise_rms_{unit}"] * u / np.sqrt(d["noise_ref_rate_hz"]),
        bias_instability=d[f"bias_instability_{unit}"] * u,
        bias_corr_time_s=d["bias_corr_time_s"],
        rate_random_walk=d[f"rate_random_walk_{unit}_per_rts"] * u,
        lsb=d[f"lsb_{unit}"] * u,
        initial_bias=d[f"initial_bias_{unit}"] * u,
        initial_sf=d["initial_sf_ppm"] * 1e-6,
        misalignment=d["misalignment_deg"] * _DEG,
        turn_on_bias=d[f"turn_on_bias_{unit}"] * u,
        bias_temp_amplitude=d[f"bias_temp_amplitude_{unit}"] * u,
        sf_temp_amplitude=d["sf_temp_amplitude_ppm"] * 1e-6,
        power_on_curve_fraction=d["power_on_curve_fraction"],
        temp_rate_coeff=d[f"temp_rate_coeff_{unit}_per_Cmin"] * u,
        misalignment_tempco=d.get("misalignment_tempco_deg_per_K", 0.0) * _DEG,
    )
    if kind == "gyro":
        return SensorSpec(
            **common,
            g_sensitivity=d["g_sensitivity_dps_per_g"] * u / G0,
            roll_coupling=tuple(float(v) * u for v in d.get("roll_coupling_dps", (0.0, 0.0))),
            roll_coupling_ref=d.get("roll_coupling_ref_dps", 300.0) * u,
            full_scale=d.get("full_scale_dps", 0.0) * u,
        )
    return SensorSpec(
        **common,
        asymmetry=d["asymmetry_ppm"] * 1e-6,
        k2=d["k2_mg_per_g2"] * 1e-3 / G0,  # [g/g^2] -> [1/(m/s^2)]
    )


def load_grade(name: str) -> SensorGrade:
    """Return the named :class:`SensorGrade` (SI units).

    Parameters
    ----------
    name : str  one of ``imutherm.imu.grades.GRADES`` (``adis16355``, ``adis16488``, ``ideal``, a sensor-library
                chip such as ``icm42688p``, ``generic_mems``), or ``GYRO+ACCEL`` (gyros of one, accelerometers of
                the other; the temperature sensor the gyro chip's)

    Raises
    ------
    InputError  for an unknown name, listing the valid ones.
    """
    if isinstance(name, SensorGrade):
        return name
    key = str(name).strip().lower()
    if "+" in key:  # "GYRO+ACCEL": the gyro sites' chip and the accel sites' chip (a layout with two IMU chips)
        g, a = (load_grade(k) for k in key.split("+", 1))
        return replace(g, name=key, description=f"gyros: {g.description}; accelerometers: {a.description}",
                       sources=g.sources + a.sources, accel=a.accel)
    if key not in GRADES:
        chips = sorted(k for k in GRADES if "chip" in GRADES[k] and k != "generic_mems")
        classic = [k for k in GRADES if "chip" not in GRADES[k]]
        raise InputError(f"sensor grade: unknown grade {name!r}; valid grades: {', '.join(classic)}, generic_mems "
                         f"and the sensor library's chips {', '.join(chips)} (or GYRO+ACCEL)")
    d = GRADES[key]
    return SensorGrade(
        name=key,
        description=d["description"],
        sources=tuple(d["sources"]),
        sample_rate_hz=float(d["sample_rate_hz"]),
        temp_sensor_tau_s=float(d["temp_sensor_tau_s"]),
        temp_sensor_offset_std_C=float(d["temp_sensor_offset_std_C"]),
        temp_sensor_lsb_C=float(d["temp_sensor_lsb_C"]),
        gyro=_spec_from_dict(d["gyro"], "gyro"),
        accel=_spec_from_dict(d["accel"], "accel"),
    )


# --------------------------------------------------------------------------- unit
@dataclass(frozen=True)
class TriadTruth:
    """Truth parameters of one sensor triad of one unit (``unit`` = rad/s or m/s^2).

    Attributes
    ----------
    M0 : ndarray (3,3) [-]          I + misalignment (rows: sensors, columns: body axes)
    sf0 : ndarray (3,) [-]          scale-factor error at 25 °C
    bias0 : ndarray (3,) [unit]     bias at 25 °C
    bias_curve : ndarray (3,6)      bias-vs-T curve parameters [c1, c2, c3, w, nu, phi], c and w in [unit]
    sf_curve : ndarray (3,6)        scale-factor-vs-T curve parameters, c and w in [-]
    temp_rate_coeff : ndarray (3,) [unit per °C/min]
    g_sens : ndarray (3,3) [rad/s per m/s^2]   gyro g-sensitivity (zero for accels)
    asym : ndarray (3,) [-]         scale-factor asymmetry (+ scale minus - scale; zero for gyros)
    k2 : ndarray (3,) [1/unit]      quadratic coefficient (zero for gyros)
    dM_dT : ndarray (3,3) [1/K]     temperature coefficient of the misalignment (off-diagonal; board /
                                    housing thermal strain): M(T) = M0 + dM_dT (T - 25 °C), row i at sensor i's T
    roll_coupling : ndarray (3,2)   gyro only (Wang et al.): per gyro [c2 [1/(rad/s)], c3 [1/(rad/s)^2]], the error
                                    c2 ω_x² + c3 ω_x³ [rad/s] the body roll rate ω_x adds to it (row 0, the roll
                                    gyro itself, is zero)
    """

    M0: np.ndarray
    sf0: np.ndarray
    bias0: np.ndarray
    bias_curve: np.ndarray
    sf_curve: np.ndarray
    temp_rate_coeff: np.ndarray
    g_sens: np.ndarray
    asym: np.ndarray
    k2: np.ndarray
    dM_dT: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    roll_coupling: np.ndarray = field(default_factory=lambda: np.zeros((3, 2)))

    def K0(self) -> np.ndarray:
        """Scale-factor / misalignment matrix at 25 °C, small-signal (no asymmetry) [-]."""
        return (1.0 + self.sf0)[:, None] * self.M0

    def bias_T(self, T_C) -> np.ndarray:
        """Bias temperature curve minus its 25 °C value [unit]; T_C (...,3) [°C]."""
        return _curve(self.bias_curve, T_C)

    def sf_T(self, T_C) -> np.ndarray:
        """Scale-factor temperature curve minus its 25 °C value [-]; T_C (...,3) [°C]."""
        return _curve(self.sf_curve, T_C)


@dataclass(frozen=True)
class ImuUnit:
    """One unit's truth parameters (drawn by :func:`draw_unit`).

    Attributes
    ----------
    grade : SensorGrade
    gyro : TriadTruth               [rad/s]
    accel : TriadTruth              [m/s^2]
    temp_offset_C : ndarray (6,) [°C]  internal temperature sensor offsets, SITES order
    temp_tau_s : ndarray (6,) [s]      internal temperature sensor lags, SITES order
    """

    grade: SensorGrade
    gyro: TriadTruth
    accel: TriadTruth
    temp_offset_C: np.ndarray
    temp_tau_s: np.ndarray


@dataclass(frozen=True)
class PowerOn:
    """Random state of one power-on (turn-on bias and small curve change).

    Attributes
    ----------
    gyro : ndarray (3,3)   [p0 [rad/s], p1 [rad/s], p2 [rad/s]] per axis: p0 + p1 x + p2 x^2
    accel : ndarray (3,3)  same for accelerometers [m/s^2]
    """

    gyro: np.ndarray
    accel: np.ndarray


def _curve(params: np.ndarray, T_C) -> np.ndarray:
    """Evaluate the per-axis smooth curve; params (3,6), T_C (...,3) [°C] -> (...,3), zero at 25 °C."""
    T = np.asarray(T_C, dtype=float)
    if T.ndim == 2 and T.shape[0] > 1 and T.strides[0] == 0:   # one row broadcast (a soak, a steady phase):
        return np.broadcast_to(_curve(params, T[:1]), T.shape)  # evaluated once, the same values
    x = (T - T_REF_C) / _X_SCALE
    c1, c2, c3, w, nu, phi = (params[:, k] for k in range(6))
    return x * (c1 + x * (c2 + x * c3)) + w * (np.sin(2 * np.pi * nu * x + phi) - np.sin(phi))  # Horner: x**3 is a pow call


def _draw_curves(rng: np.random.Generator, amplitude: float) -> np.ndarray:
    """Three random unit-specific curves with peak |value| over -40..70 °C = amplitude * U(0.5, 1.5)."""
    out = np.zeros((3, 6))
    if amplitude == 0.0:
        return out
    Tg = np.linspace(*T_RANGE_C, 221)
    for i in range(3):
        p = np.array([rng.normal(), rng.normal(), rng.normal(), 0.35 * rng.normal(),
                      rng.uniform(0.6, 1.4), rng.uniform(0, 2 * np.pi)])
        peak = np.max(np.abs(_curve(p[None, :].repeat(3, 0), np.stack([Tg] * 3, -1))[:, 0]))
        scale = amplitude * rng.uniform(0.5, 1.5) / peak
        p[[0, 1, 2, 3]] *= scale
        out[i] = p
    return out


def _draw_triad(spec: SensorSpec, rng: np.random.Generator, kind: str) -> TriadTruth:
    mis = rng.normal(0.0, spec.misalignment, (3, 3))
    np.fill_diagonal(mis, 0.0)
    return TriadTruth(
        M0=np.eye(3) + mis,
        sf0=rng.normal(0.0, spec.initial_sf, 3),
        bias0=rng.normal(0.0, spec.initial_bias, 3),
        bias_curve=_draw_curves(rng, spec.bias_temp_amplitude),
        sf_curve=_draw_curves(rng, spec.sf_temp_amplitude),
        temp_rate_coeff=rng.normal(0.0, spec.temp_rate_coeff, 3),
        g_sens=rng.normal(0.0, spec.g_sensitivity, (3, 3)) if kind == "gyro" else np.zeros((3, 3)),
        asym=rng.normal(0.0, spec.asymmetry, 3) if kind == "accel" else np.zeros(3),
        k2=rng.normal(0.0, spec.k2, 3) if kind == "accel" else np.zeros(3),
    )


def draw_roll_coupling(spec: SensorSpec, rng: np.random.Generator) -> np.ndarray:
    """Roll-coupling coefficients (3,2) of one unit's gyros: row 0 zero, rows 1-2 [c2, c3] with
    c2 ~ N(0, (e2 / W²)²), c3 ~ N(0, (e3 / W³)²), (e2, e3) = spec.roll_coupling [rad/s], W = spec.roll_coupling_ref."""
    e2, e3 = spec.roll_coupling
    W = spec.roll_coupling_ref
    out = np.zeros((3, 2))
    if e2 > 0 or e3 > 0:
        out[1:] = rng.normal(0.0, 1.0, (2, 2)) * np.array([e2 / W**2, e3 / W**3])
    return out


def _offdiag(rng, sigma: float) -> np.ndarray:
    m = rng.normal(0.0, sigma, (3, 3)) if sigma > 0 else np.zeros((3, 3))
    np.fill_diagonal(m, 0.0)
    return m


def _ideal_triad() -> TriadTruth:
    z3, z33 = np.zeros(3), np.zeros((3, 3))
    return TriadTruth(M0=np.eye(3), sf0=z3, bias0=z3, bias_curve=np.zeros((3, 6)), sf_curve=np.zeros((3, 6)),
                      temp_rate_coeff=z3, g_sens=z33, asym=z3, k2=z3)


def draw_unit(grade: str | SensorGrade, rng: np.random.Generator, *, ideal: bool = False) -> ImuUnit:
    """Draw one unit's truth parameters from a grade.

    Parameters
    ----------
    grade : str | SensorGrade   grade name (see :func:`load_grade`) or grade
    rng : numpy.random.Generator
    ideal : bool                if True every deterministic error (bias, scale, misalignment,
                                temperature curves, dynamic terms, temperature-sensor offset and lag)
                                is zero; the grade's noise is still applied unless
                                ``simulate_imu(..., noise=False)``. Grade ``ideal`` has zero noise too.

    Returns
    -------
    ImuUnit

    Examples
    --------
    >>> import numpy as np
    >>> from imutherm.imu.sensor_model import draw_unit
    >>> unit = draw_unit("adis16355", np.random.default_rng(0))     # one unit of the grade, from a seed
    >>> unit.grade.name, unit.grade.sample_rate_hz                   # [Hz]
    ('adis16355', 100.0)
    >>> np.degrees(unit.gyro.bias0).round(3).tolist()               # its gyro biases at 25 °C [°/s]
    [-1.163, -0.109, -0.623]
    """
    g = load_grade(grade)
    if not isinstance(rng, np.random.Generator):
        raise InputError(f"draw_unit: rng must be a numpy.random.Generator, got {type(rng).__name__}")
    if ideal:
        return ImuUnit(grade=g, gyro=_ideal_triad(), accel=_ideal_triad(),
                       temp_offset_C=np.zeros(6), temp_tau_s=np.zeros(6))
    gyro = _draw_triad(g.gyro, rng, "gyro")
    accel = _draw_triad(g.accel, rng, "accel")
    # thermal misalignment from a generator keyed by this generator's seed sequence (not by its state, and
    # without rng.spawn, which counts its calls): the main stream and every other draw are unchanged, and
    # two generators made from the same seed sequence draw the same unit (common random numbers)
    ss = getattr(rng.bit_generator, "seed_seq", None)
    if ss is None:
        raise InputError("draw_unit: rng must come from a SeedSequence (e.g. numpy.random.default_rng(seed))")
    trng = np.random.default_rng(np.random.SeedSequence(ss.entropy, spawn_key=tuple(ss.spawn_key) + (0x7E3C,)))
    gyro = replace(gyro, dM_dT=_offdiag(trng, g.gyro.misalignment_tempco))
    accel = replace(accel, dM_dT=_offdiag(trng, g.accel.misalignment_tempco))
    # Wang et al.'s high-rate roll coupling, from a third keyed stream (the unit's other draws are unchanged)
    crng = np.random.default_rng(np.random.SeedSequence(ss.entropy, spawn_key=tuple(ss.spawn_key) + (0x5011,)))
    gyro = replace(gyro, roll_coupling=draw_roll_coupling(g.gyro, crng))
    off = np.clip(rng.normal(0.0, g.temp_sensor_offset_std_C, 6), -3 * g.temp_sensor_offset_std_C,
                  3 * g.temp_sensor_offset_std_C)
    tau = np.full(6, g.temp_sensor_tau_s)
    return ImuUnit(grade=g, gyro=gyro, accel=accel, temp_offset_C=off, temp_tau_s=tau)


def draw_power_on(unit: ImuUnit, rng: np.random.Generator) -> PowerOn:
    """Draw the random state of one power-on of ``unit`` (turn-on bias, curve change).

    p0 ~ N(0, turn_on_bias); p1, p2 ~ N(0, fraction * peak / 2) with peak the unit's own curve peak [unit].
    """
    out = []
    for spec, triad in ((unit.grade.gyro, unit.gyro), (unit.grade.accel, unit.accel)):
        Tg = np.linspace(*T_RANGE_C, 111)
        peak = np.max(np.abs(triad.bias_T(np.stack([Tg] * 3, -1))), axis=0)  # (3,)
        p = np.empty((3, 3))
        p[:, 0] = rng.normal(0.0, 1.0, 3) * spec.turn_on_bias
        p[:, 1:] = rng.normal(0.0, 1.0, (3, 2)) * (spec.power_on_curve_fraction * peak / 2.0)[:, None]
        out.append(p)
    return PowerOn(gyro=out[0], accel=out[1])


def zero_power_on() -> PowerOn:
    """A power-on with no random component."""
    return PowerOn(gyro=np.zeros((3, 3)), accel=np.zeros((3, 3)))


# --------------------------------------------------------------------------- samples
@dataclass(frozen=True)
class ImuSamples:
    """Sensor outputs of one run.

    Attributes
    ----------
    t : ndarray (N,) [s]
    gyro : ndarray (N,3) [rad/s]     measured body rate
    accel : ndarray (N,3) [m/s^2]    measured specific force in body axes
    temp_C : ndarray (N,6) [°C]      temperatures reported by each sensor's internal temperature
                                     sensor, SITES order
    """

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    temp_C: np.ndarray


def _as_array(name: str, a, shape_tail: tuple, n: int | None) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: not a numeric array ({exc})") from None
    want = ("N",) + shape_tail
    if arr.ndim != len(want) or arr.shape[1:] != shape_tail or (n is not None and arr.shape[0] != n):
        exp = "(" + ", ".join(str(n if (k == 0 and n is not None) else s) for k, s in enumerate(want)) + ")"
        raise InputError(f"{name}: shape {arr.shape} is invalid; expected {exp}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: contains NaN or infinite values; all values must be finite")
    return arr


def validate_samples(samples: ImuSamples) -> None:
    """Raise InputError unless ``samples`` has consistent shapes (N,), (N,3), (N,3), (N,6)."""
    t = _as_array("samples.t", samples.t, (), None)
    n = t.shape[0]
    _as_array("samples.gyro", samples.gyro, (3,), n)
    _as_array("samples.accel", samples.accel, (3,), n)
    _as_array("samples.temp_C", samples.temp_C, (6,), n)


def temperature_sensor_lag(t, T_die_C, tau_s) -> np.ndarray:
    """First-order lag of a die temperature as seen by an internal temperature sensor.

    dy/dt = (T_die - y)/tau, y(t0) = T_die(t0) (steady start). Discretised exactly for a
    die temperature that is linear between samples (first-order hold).

    Parameters
    ----------
    t : ndarray (N,) [s]
    T_die_C : ndarray (N,) or (N,k) [°C]
    tau_s : float or ndarray (k,) [s]  (0 = no lag)

    Returns
    -------
    ndarray like T_die_C [°C]
    """
    t = np.asarray(t, float)
    u = np.asarray(T_die_C, float)
    squeeze = u.ndim == 1
    if squeeze:
        u = u[:, None]
    tau = np.broadcast_to(np.asarray(tau_s, float), (u.shape[1],))
    y = u.copy()
    if u.shape[0] < 2:
        return y[:, 0] if squeeze else y
    dt = np.diff(t)[:, None]
    lag = tau > 0
    if np.any(lag):
        tl = tau[lag][None, :]
        a = np.exp(-dt / tl)  # (N-1,k)
        g = 1.0 - tl / dt * (1.0 - a)  # weight of the input increment (first-order hold)
        ul = u[:, lag]
        yl = np.empty_like(ul)
        yl[0] = ul[0]
        du = np.diff(ul, axis=0)
        drive = (1.0 - a) * ul[:-1] + g * du
        if np.allclose(dt, dt[0], rtol=1e-9, atol=0.0):  # uniform step: linear filter, vectorised
            for j in range(ul.shape[1]):
                aj = a[0, j]
                yl[1:, j], _ = lfilter([1.0], [1.0, -aj], drive[:, j], zi=[aj * ul[0, j]])
        else:
            for k in range(ul.shape[0] - 1):  # general recursion
                yl[k + 1] = a[k] * yl[k] + drive[k]
        y[:, lag] = yl
    return y[:, 0] if squeeze else y


def _gauss_markov(rng, n, k, sigma, tau_c, dt):
    phi = np.exp(-dt / tau_c)
    w = rng.standard_normal((n, k)) * (sigma * np.sqrt(1.0 - phi**2))
    w[0] = rng.standard_normal(k) * sigma  # stationary start
    return lfilter([1.0], [1.0, -phi], w, axis=0)


def _triad_output(triad: TriadTruth, spec: SensorSpec, x, T, dTdt_min, f_b, p_on, rng, dt, noise, kind):
    u = x @ triad.M0.T  # (N,3) input on the sensitive axes
    if np.any(triad.dM_dT):  # thermal misalignment, row i at sensor i's temperature
        u = u + (T - T_REF_C) * (x @ triad.dM_dT.T)
    sf = 1.0 + triad.sf0 + triad.sf_T(T) + 0.5 * triad.asym * np.sign(u)
    xx = (T - T_REF_C) / _X_SCALE
    y = sf * u + triad.k2 * u**2 + triad.bias0 + triad.bias_T(T) + triad.temp_rate_coeff * dTdt_min
    if kind == "gyro":
        y = y + f_b @ triad.g_sens.T
        if np.any(triad.roll_coupling):  # Wang et al.: high roll rate couples into the other gyros
            wx = x[:, :1]
            y = y + triad.roll_coupling[:, 0] * wx**2 + triad.roll_coupling[:, 1] * wx**3
    y = y + p_on[:, 0] + p_on[:, 1] * xx + p_on[:, 2] * xx**2
    if noise:
        n = y.shape[0]
        fs = 1.0 / dt
        if spec.noise_density > 0:
            y = y + rng.standard_normal((n, 3)) * (spec.noise_density * np.sqrt(fs))
        if spec.bias_instability > 0:  # Allan floor of the GM process = the grade's bias instability
            y = y + _gauss_markov(rng, n, 3, spec.bias_instability / GM_ADEV_PEAK, spec.bias_corr_time_s, dt)
        if spec.rate_random_walk > 0:
            y = y + np.cumsum(rng.standard_normal((n, 3)) * (spec.rate_random_walk * np.sqrt(dt)), axis=0)
        if spec.lsb > 0:
            y = np.round(y / spec.lsb) * spec.lsb
    return y


def simulate_imu(unit: ImuUnit, t, omega_b, f_b, temp_C, rng: np.random.Generator | None, *,
                 noise: bool = True, power_on: PowerOn | None = None) -> ImuSamples:
    """Simulate the sensor outputs of ``unit`` for a given true motion and die temperatures.

    Parameters
    ----------
    unit : ImuUnit
    t : ndarray (N,) [s]               strictly increasing sample times (uniform spacing assumed for noise)
    omega_b : ndarray (N,3) [rad/s]    true body rate
    f_b : ndarray (N,3) [m/s^2]        true specific force at the sensor, body axes
    temp_C : ndarray (N,6) [°C]        true die temperature per site, SITES order
    rng : numpy.random.Generator       source of all randomness (may be None when noise=False)
    noise : bool                       False: deterministic, noise-free output (no white / Gauss-Markov /
                                       random-walk noise, no quantisation, no power-on random draw)
    power_on : PowerOn | None          the power-on state to use; None draws one from ``rng``
                                       (noise=True) or uses none (noise=False). Pass the same state to
                                       several calls to model one continuous session.

    Returns
    -------
    ImuSamples   (temp_C = reported temperatures: lag + offset + quantisation)

    Raises
    ------
    InputError   wrong shapes, non-finite values, non-increasing t, missing rng.

    Examples
    --------
    Ten seconds level and at rest (body axes forward-right-down: the specific force is −g along z), the dies
    at 60 °C:

    >>> import numpy as np
    >>> from imutherm.imu.sensor_model import G0, draw_unit, simulate_imu
    >>> rng = np.random.default_rng(0)
    >>> unit = draw_unit("adis16355", rng)
    >>> t = np.arange(0.0, 10.0, 0.01)                                  # [s], 100 Hz
    >>> f_b = np.tile([0.0, 0.0, -G0], (t.size, 1))                     # [m/s^2]
    >>> raw = simulate_imu(unit, t, np.zeros((t.size, 3)), f_b, np.full((t.size, 6), 60.0), rng)
    >>> raw.gyro.shape, raw.accel.shape, raw.temp_C.shape
    ((1000, 3), (1000, 3), (1000, 6))
    >>> np.degrees(raw.gyro.mean(axis=0)).round(2).tolist()             # gyro error at 60 °C [°/s]
    [-1.55, -0.21, -0.77]
    >>> (1e3 * (raw.accel.mean(axis=0) - f_b[0]) / G0).round(1).tolist()  # accelerometer error [mg]
    [-13.6, 9.9, -36.9]
    """
    t = _as_array("t", t, (), None)
    n = t.shape[0]
    if n < 1:
        raise InputError("t: empty; need at least one sample")
    omega_b = _as_array("omega_b", omega_b, (3,), n)
    f_b = _as_array("f_b", f_b, (3,), n)
    temp_C = _as_array("temp_C", temp_C, (6,), n)
    if n > 1 and np.any(np.diff(t) <= 0):
        raise InputError("t: must be strictly increasing")
    if noise and not isinstance(rng, np.random.Generator):
        raise InputError("rng: a numpy.random.Generator is required when noise=True")
    dt = float(np.median(np.diff(t))) if n > 1 else 1.0 / unit.grade.sample_rate_hz
    if power_on is None:
        power_on = draw_power_on(unit, rng) if noise else zero_power_on()
    if n > 1:
        dTdt_min = np.gradient(temp_C, t, axis=0) * 60.0  # [°C/min]
    else:
        dTdt_min = np.zeros_like(temp_C)
    g = unit.grade
    gyro = _triad_output(unit.gyro, g.gyro, omega_b, temp_C[:, :3], dTdt_min[:, :3], f_b, power_on.gyro,
                         rng, dt, noise, "gyro")
    accel = _triad_output(unit.accel, g.accel, f_b, temp_C[:, 3:], dTdt_min[:, 3:], f_b, power_on.accel,
                          rng, dt, noise, "accel")
    rep = temperature_sensor_lag(t, temp_C, unit.temp_tau_s) + unit.temp_offset_C
    if noise and g.temp_sensor_lsb_C > 0:
        rep = np.round(rep / g.temp_sensor_lsb_C) * g.temp_sensor_lsb_C
    return ImuSamples(t=t.copy(), gyro=gyro, accel=accel, temp_C=rep)


# --------------------------------------------------------------------------- (de)serialisation
def unit_to_dict(unit: ImuUnit) -> dict[str, Any]:
    """JSON-ready dict of a unit (grade by name; arrays as lists)."""
    def triad(tr: TriadTruth):
        return {f.name: np.asarray(getattr(tr, f.name)).tolist() for f in fields(tr)}
    return {"grade": unit.grade.name, "gyro": triad(unit.gyro), "accel": triad(unit.accel),
            "temp_offset_C": unit.temp_offset_C.tolist(), "temp_tau_s": unit.temp_tau_s.tolist()}


def unit_from_dict(d: dict[str, Any]) -> ImuUnit:
    """Inverse of :func:`unit_to_dict`."""
    def triad(x):  # a unit written before a field existed gets that field's default (zeros)
        return TriadTruth(**{k: np.asarray(v, float) for k, v in x.items()})
    return ImuUnit(grade=load_grade(d["grade"]), gyro=triad(d["gyro"]), accel=triad(d["accel"]),
                   temp_offset_C=np.asarray(d["temp_offset_C"], float), temp_tau_s=np.asarray(d["temp_tau_s"], float))
