"""Wang et al.'s composite gyro calibration: rate table, least squares, then the high-rate roll coupling.

Procedure (simulated on one drawn unit, 25 °C, one power-on, rate axis
vertical, the unit's axes on the table's axes):

1. **Initial calibration** (Wang et al.): rate table about each axis at ±10..±300
   °/s in 10 °/s steps, CW and CCW (180 runs); least squares ``N = K ω + D``
   (:func:`imutherm.imu.calibration.fit_scale_bias`). This removes scale factor,
   misalignment and bias, and the part of the roll coupling a linear map can
   take (the cubic's projection on ω_x).
2. **Coupling fit**: on the roll-axis runs of step 1, the y and z gyros'
   residual after step 1 as a function of the calibrated roll rate, fitted by

   * ``poly``: a cubic polynomial per axis (least squares; 4 coefficients);
   * ``mlp``: Wang et al.'s network, one hidden layer of 30 nodes (scikit-learn
     ``MLPRegressor``, tanh, L-BFGS, L2 alpha 1e-3, input scaled by 300 °/s,
     ``random_state`` 0): 122 weights on 60 rates.

3. **Test**: 29 roll rates drawn uniformly in ±(10..300) °/s off the 10 °/s
   grid (Wang et al.'s 29 test rates; none used in the fits), about the roll
   axis; RMSE over them of each gyro's calibrated output minus the true
   rate [°/s], for step 1 alone and with each coupling model.

Wang et al.'s figures (RMSE 0.0204 / 0.0459 / 0.0154 for x / y / z after
calibration, its figure 2) are over its 29 test rates about each axis; it
shows the coupling only as a figure (3) and a table of coefficients we do
not have.

The truth model's coupling is itself a polynomial (:mod:`imutherm.imu.sensor_model`),
so the cubic fits it exactly up to noise; the comparison shows what the
network costs on the same data, not which model a real sensor needs.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from imutherm import InputError
from imutherm.imu.calibration import fit_scale_bias
from imutherm.imu.sensor_model import G0, ImuUnit, draw_power_on, simulate_imu

_DEG = np.pi / 180.0
#: Wang et al. figure 2: gyro RMSE after its calibration over 29 test rates, x / y / z [°/s]
PAPER_RMSE_DPS = (0.0204, 0.0459, 0.0154)
MODELS = ("poly", "mlp")


@dataclass(frozen=True)
class RollCouplingRig:
    """Rate-table settings: rates_dps [°/s] calibration rate magnitudes (CW and CCW), dwell_s [s] per rate,
    settle_s [s] discarded at the start of each dwell, n_test [-] test rates, test_range_dps [°/s]."""

    rates_dps: tuple = tuple(float(r) for r in range(10, 301, 10))
    dwell_s: float = 10.0  # [ASSUMED] table dwell; Wang et al. does not state one
    settle_s: float = 0.2
    n_test: int = 29
    test_range_dps: tuple = (10.0, 300.0)

    def __post_init__(self):
        if not (0 <= self.settle_s < self.dwell_s):
            raise InputError(f"roll-coupling rig: settle_s={self.settle_s!r}, dwell_s={self.dwell_s!r}; valid: "
                             "0 <= settle_s < dwell_s")
        if self.n_test < 1:
            raise InputError(f"roll-coupling rig: n_test={self.n_test!r}; valid: >= 1")


@dataclass(frozen=True)
class RollCouplingResult:
    """Result of :func:`calibrate_roll_coupling`.

    K : (3,3) [-], D : (3,) [rad/s]       step-1 least-squares calibration ``N = K ω + D``
    poly : (2,4)                          cubic per y / z gyro, highest power first, in °/s of ω_x [°/s]
    train_rates_dps : (R,) [°/s]          roll rates of the coupling fit
    train_residual_dps : (R,2) [°/s]      y / z residual after step 1 on them
    test_rates_dps : (29,) [°/s]          test roll rates
    test_error_dps : dict                 {"linear" | "poly" | "mlp": (29,3) calibrated minus true rate [°/s]}
    rmse_dps : dict                       {"linear" | "poly" | "mlp": [x, y, z] RMSE over the test rates [°/s]}
    truth_coupling : (3,2)                the unit's true [c2, c3] (rad/s units, see sensor_model)
    runtime_s : float [s]
    """

    K: np.ndarray
    D: np.ndarray
    poly: np.ndarray
    train_rates_dps: np.ndarray
    train_residual_dps: np.ndarray
    test_rates_dps: np.ndarray
    test_error_dps: dict = field(repr=False)
    rmse_dps: dict = field(default_factory=dict)
    truth_coupling: np.ndarray = field(default_factory=lambda: np.zeros((3, 2)))
    runtime_s: float = 0.0

    def to_json(self) -> dict:
        """JSON-ready dict (angles in °/s)."""
        return {
            "procedure": "roll-coupling (Wang et al. composite calibration)",
            "rmse_dps": {k: list(map(float, v)) for k, v in self.rmse_dps.items()},
            "paper_rmse_dps": list(PAPER_RMSE_DPS),
            "paper_source": "Wang et al. figure 2 (29 test rates per axis, after calibration)",
            "poly_coefficients_dps": self.poly.tolist(),
            "poly_form": "residual_j = p0 w^3 + p1 w^2 + p2 w + p3, w = calibrated roll rate [deg/s]",
            "truth_coupling": {"c2_per_radps": self.truth_coupling[:, 0].tolist(),
                               "c3_per_radps2": self.truth_coupling[:, 1].tolist()},
            "linear_K": self.K.tolist(), "linear_D_dps": (self.D / _DEG).tolist(),
            "train_rates_dps": self.train_rates_dps.tolist(),
            "train_residual_dps": self.train_residual_dps.tolist(),
            "test_rates_dps": self.test_rates_dps.tolist(),
            "test_error_dps": {k: v.tolist() for k, v in self.test_error_dps.items()},
            "runtime_s": self.runtime_s,
        }


def _table_means(unit: ImuUnit, rng, omega: np.ndarray, rig: RollCouplingRig, power_on) -> np.ndarray:
    """Mean gyro output (R,3) [rad/s] of constant-rate runs omega (R,3) [rad/s], rate axis vertical."""
    fs = unit.grade.sample_rate_hz
    m = int(round(rig.dwell_s * fs))
    skip = int(round(rig.settle_s * fs))
    axis = np.argmax(np.abs(omega), axis=1)
    f = G0 * np.eye(3)[axis]  # the tested axis up
    n = omega.shape[0] * m
    s = simulate_imu(unit, np.arange(n) / fs, np.repeat(omega, m, axis=0), np.repeat(f, m, axis=0),
                     np.full((n, 6), 25.0), rng, power_on=power_on)
    return s.gyro.reshape(omega.shape[0], m, 3)[:, skip:].mean(axis=1)


def _mlp(seed: int = 0):
    try:
        from sklearn.neural_network import MLPRegressor
    except ImportError:  # pragma: no cover - declared in pyproject
        raise InputError("roll coupling: model 'mlp' needs scikit-learn (pip install scikit-learn)") from None
    return MLPRegressor(hidden_layer_sizes=(30,), activation="tanh", solver="lbfgs", alpha=1e-3, max_iter=5000,
                        tol=1e-10, random_state=seed)


def calibrate_roll_coupling(unit: ImuUnit, rng: np.random.Generator,
                            rig: RollCouplingRig = RollCouplingRig()) -> RollCouplingResult:
    """Run the three steps of the module docstring on ``unit``; all randomness from ``rng``."""
    t0 = time.perf_counter()
    p_on = draw_power_on(unit, rng)
    rates = np.asarray(rig.rates_dps, float)
    om = []
    for a in range(3):
        for r in rates:
            for s in (1.0, -1.0):
                om.append(s * r * _DEG * np.eye(3)[a])
    om = np.array(om)
    N = _table_means(unit, rng, om, rig, p_on)
    K, D, _ = fit_scale_bias(om, N)
    Kinv = np.linalg.inv(K)

    def linear(Nm):
        return (Nm - D) @ Kinv.T

    roll = np.abs(om[:, 0]) > 0
    w_cal = linear(N[roll])  # calibrated rates on the roll-axis runs [rad/s]
    wx = w_cal[:, 0] / _DEG
    res = (w_cal[:, 1:] - om[roll, 1:]) / _DEG  # y / z residual [°/s]
    poly = np.stack([np.polyfit(wx, res[:, j], 3) for j in range(2)])
    scale = rig.test_range_dps[1]
    net = _mlp().fit(wx[:, None] / scale, res)

    lo, hi = rig.test_range_dps
    mags = rng.uniform(lo, hi, rig.n_test)
    mags = np.where(np.isclose(mags % 10.0, 0.0, atol=0.5), mags + 1.0, mags)  # off the calibration grid
    test = np.zeros((rig.n_test, 3))
    test[:, 0] = np.where(rng.random(rig.n_test) < 0.5, -1.0, 1.0) * mags * _DEG
    wt = linear(_table_means(unit, rng, test, rig, p_on))
    base = (wt - test) / _DEG
    wtx = wt[:, 0] / _DEG
    errs = {"linear": base}
    corr_poly = np.stack([np.polyval(poly[j], wtx) for j in range(2)], axis=1)
    errs["poly"] = base - np.hstack([np.zeros((rig.n_test, 1)), corr_poly])
    corr_mlp = net.predict(wtx[:, None] / scale)
    errs["mlp"] = base - np.hstack([np.zeros((rig.n_test, 1)), corr_mlp])
    rmse = {k: np.sqrt(np.mean(v**2, axis=0)) for k, v in errs.items()}
    return RollCouplingResult(K=K, D=D, poly=poly, train_rates_dps=wx, train_residual_dps=res,
                              test_rates_dps=test[:, 0] / _DEG, test_error_dps=errs, rmse_dps=rmse,
                              truth_coupling=np.asarray(unit.gyro.roll_coupling, float).copy(),
                              runtime_s=time.perf_counter() - t0)


def compensate_roll_coupling(gyro, poly) -> np.ndarray:
    """Remove the fitted coupling from calibrated gyro samples (N,3) [rad/s]: y, z minus the cubic in ω_x."""
    g = np.array(gyro, float)
    wx = g[:, 0] / _DEG
    for j in range(2):
        g[:, 1 + j] -= np.polyval(np.asarray(poly)[j], wx) * _DEG
    return g
