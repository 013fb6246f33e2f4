"""Lin et al.'s dynamic calibration on a sinusoidal linear-overload table (simulated).

The table (a Scotch-yoke crank, so the motion is a pure sinusoid) moves the
unit along one body axis, ``x(t) = r sin(ω t)``, ``A(t) = -r ω² sin(ω t)``,
peak ``A0 = r ω²`` = 1..10 g; crank radius ``r`` = 0.25 m [ASSUMED: Lin et al.
gives none; 10 g then needs 3.2 Hz]. A linear grating ruler gives the table
position, hence A(t) and the half periods. Three mountings (Lin et al. §5.2):
the moved axis x, y or z, another axis up (1 g). Before each load the table
rests 10 s at its zero (the routine static test that gives the bias, which
Lin et al. takes as known).

Model (:mod:`imutherm.imu.sensor_model`), per accelerometer on the moved axis,
``y = b + K1 A + (Ka/2)|A| + K2 A²`` (Ka = scale-factor asymmetry: the + and -
scale factors differ by Ka), and per gyro ``y = D0 + D1 · A`` (g-sensitive
drift; D1 = the gyro's g-sensitivity to the moved axis).

Estimators, from pulse sums (``Σ y dt``: velocity / angle increments, what a
pulse-output unit counts) over the positive and negative half periods of
each cycle, with the half periods from the ruler:

* **D1** (Lin et al. eq. 15-16): positive minus negative half-period sums of the
  gyro, divided by the same difference of the ruler's ``Σ A dt`` (the velocity
  change ``V_max - V_min``); the bias cancels.
* **K1** the same way from the accelerometer (the difference holds the odd terms).
* **Ka and K2**: the *sum* of the two half periods holds the even terms
  ``b T + (Ka/2) Σ|A| dt + K2 Σ A² dt``, which one sum cannot split (Lin et al.'s
  own equations 8-11 separate them by dropping small products of a model whose
  equations are images we do not have). We sum the pulses of both halves in
  ``bands`` bands of |A| (equal phase widths of each quarter period): the
  bands' different ratios of T, ``Σ|A| dt`` and ``Σ A² dt`` give b, Ka and K2 per
  load by least squares, and all loads and power-ons together (one bias per
  run, shared Ka and K2) give the "joint" values. The bias comes from the run
  itself: the rest's bias has drifted by the bias instability (0.7 mg) by then,
  which alone is the asymmetry term's size at 10 g.

Checked against the unit's truth (:func:`truth_coefficients`). By default the
truth model holds Ka, K2 and D1 constant with load and across power-ons. With
a :class:`LoadDependence` (``calibrate_overload(..., dependence=...)``,
``imutherm calibrate --procedure overload --load-dependence``) the unit behaves
as Lin et al. reports its unit did: Ka grows with load, K2 and D1 shrink with
load, and all three change from power-on to power-on; the procedure's per-load
values are then checked against the truth's per-load values.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from imutherm import InputError
from imutherm.imu.sensor_model import G0, ImuSamples, ImuUnit, draw_power_on, simulate_imu, zero_power_on

AXES = "xyz"
#: Lin et al. §5.2: (moved axis, up axis) of the three mountings
MOUNTINGS = ((0, 1), (1, 0), (2, 0))


@dataclass(frozen=True)
class OverloadRig:
    """Table settings: loads_g [g] peak accelerations, crank_m [m] crank radius, cycles [-] recorded cycles per
    load (after one discarded), rest_s [s] rest before each load, power_ons [-] repetitions of the whole test,
    bands [-] |A| bands per quarter period for the even terms."""

    loads_g: tuple = tuple(float(g) for g in range(1, 11))
    crank_m: float = 0.25
    cycles: int = 40
    rest_s: float = 10.0
    power_ons: int = 3
    bands: int = 6

    def __post_init__(self):
        if not self.loads_g or min(self.loads_g) <= 0 or max(self.loads_g) > 50:
            raise InputError(f"overload rig: loads_g={self.loads_g!r}; valid: peak loads in (0, 50] g")
        if not (self.crank_m > 0 and self.cycles >= 2 and self.rest_s > 0 and self.power_ons >= 1 and self.bands >= 3):
            raise InputError("overload rig: crank_m > 0 [m], cycles >= 2, rest_s > 0 [s], power_ons >= 1, bands >= 3 required")


@dataclass(frozen=True)
class LoadDependence:
    """Lin et al.'s findings as a truth model: the dynamic coefficients of a run at peak load A0.

    Form (amplitude-dependent, as a describing function: the unit's response to a sinusoid of peak A0 is the
    model ``y = b + K1 A + (Ka/2)|A| + K2 A²`` with coefficients that depend on A0), for each power-on p::

        Ka(A0) = Ka (1 + asym_per_g (A0/g0 - 1)) (1 + power_on_rel ε_p)
        K2(A0) = K2 (1 + k2_per_g  (A0/g0 - 1)) (1 + power_on_rel ε_p')
        D1(A0) = D1 (1 + d1_per_g  (A0/g0 - 1)) (1 + power_on_rel ε_p'')

    (Ka, K2, D1 the unit's 1 g values; ε ~ N(0, 1) per power-on, coefficient and axis / matrix term).
    Sizes [ASSUMED]: Lin et al. plots its results in normalised units (its figures 5-9), so it gives trends, not
    sizes: Ka +6 %/g (x1.54 at 10 g), K2 and D1 -5 %/g (x0.55 at 10 g), power-on change 10 % (1 sigma).
    asym_per_g, k2_per_g, d1_per_g [1/g]; power_on_rel [-].
    """

    asym_per_g: float = 0.06
    k2_per_g: float = -0.05
    d1_per_g: float = -0.05
    power_on_rel: float = 0.10

    def __post_init__(self):
        for name in ("asym_per_g", "k2_per_g", "d1_per_g", "power_on_rel"):
            v = getattr(self, name)
            if not np.isfinite(v) or abs(v) >= (0.5 if name == "power_on_rel" else 0.1):
                raise InputError(f"LoadDependence: {name}={v!r} is invalid; valid: |value| < "
                                 f"{0.5 if name == 'power_on_rel' else 0.1} (a coefficient must keep its sign to 10 g)")


@dataclass(frozen=True)
class OverloadCoefficients:
    """Dynamic error coefficients: asym (3,) [-] accelerometer scale-factor asymmetry Ka, k2 (3,) [1/(m/s^2)]
    quadratic term, D1 (3,3) [rad/s per m/s^2] gyro g-sensitivity (row: gyro, column: load axis)."""

    asym: np.ndarray
    k2: np.ndarray
    D1: np.ndarray

    def to_json(self) -> dict:
        """Datasheet units: Ka [ppm], K2 [mg/g²] (= 1e-3/g0 per (m/s^2)^-1... see key), D1 [°/s/g]."""
        return {"asym_ppm": (self.asym * 1e6).tolist(), "k2_mg_per_g2": (self.k2 * G0 * 1e3).tolist(),
                "D1_dps_per_g": np.degrees(self.D1 * G0).tolist()}


def truth_coefficients(unit: ImuUnit) -> OverloadCoefficients:
    """The unit's own Ka, K2, D1 (truth model values, the check of the procedure)."""
    return OverloadCoefficients(asym=np.asarray(unit.accel.asym, float).copy(),
                                k2=np.asarray(unit.accel.k2, float).copy(),
                                D1=np.asarray(unit.gyro.g_sens, float).copy())


@dataclass(frozen=True)
class OverloadResult:
    """Result of :func:`calibrate_overload`.

    loads_g : (L,) [g]
    per_load : dict   {"asym" | "k2" | "K1": (P,3,L), "D1": (P,3,3,L)} per power-on, axis (moved axis for D1's
                      last-but-one index), load; SI units as OverloadCoefficients (K1 [-])
    joint : OverloadCoefficients   all loads and power-ons together (least squares / mean)
    truth : OverloadCoefficients   the unit's 1 g values
    runtime_s : float [s]
    truth_per_load : dict | None   with a :class:`LoadDependence`: the truth's "asym", "k2", "D1" per power-on,
                                   axis and load (shapes as per_load)
    dependence : LoadDependence | None
    """

    loads_g: np.ndarray
    per_load: dict = field(repr=False)
    joint: OverloadCoefficients = None
    truth: OverloadCoefficients = None
    runtime_s: float = 0.0
    truth_per_load: dict | None = field(default=None, repr=False)
    dependence: LoadDependence | None = None

    def to_json(self) -> dict:
        """JSON-ready dict in datasheet units (ppm, mg/g², °/s/g)."""
        pl = self.per_load
        return {
            "procedure": "overload (Lin et al. sinusoidal linear-overload table)",
            "loads_g": self.loads_g.tolist(),
            "joint": self.joint.to_json(), "truth": self.truth.to_json(),
            "per_load": {"asym_ppm": (pl["asym"] * 1e6).tolist(),
                         "k2_mg_per_g2": (pl["k2"] * G0 * 1e3).tolist(),
                         "D1_dps_per_g": np.degrees(pl["D1"] * G0).tolist(),
                         "index_order": "[power_on][axis][load] (D1: [power_on][gyro][load axis][load])"},
            "runtime_s": self.runtime_s,
            **({} if self.truth_per_load is None else {
                "load_dependence": {**{k: getattr(self.dependence, k) for k in
                                       ("asym_per_g", "k2_per_g", "d1_per_g", "power_on_rel")},
                                    "truth_per_load": {"asym_ppm": (self.truth_per_load["asym"] * 1e6).tolist(),
                                                       "k2_mg_per_g2": (self.truth_per_load["k2"] * G0 * 1e3).tolist(),
                                                       "D1_dps_per_g": np.degrees(self.truth_per_load["D1"] * G0).tolist()},
                                    "trends": self.trends()}}),
        }

    def trends(self) -> dict:
        """Change per g of each coefficient, recovered vs truth: a weighted least-squares line through the per-load
        values of every power-on (weights A0² for Ka and D1, A0⁴ for K2: the per-load noise falls as 1/A0 and
        1/A0², the even and g-sensitive terms growing as A0 and A0² against a fixed noise), per axis; D1 over its
        diagonal (each gyro's sensitivity to its own axis). Slopes in datasheet units per g (ppm/g, mg/g²/g,
        °/s/g/g) and relative to the truth's 1 g value [1/g]. Needs truth_per_load."""
        if self.truth_per_load is None:
            raise InputError("overload trends: need a run with a load dependence")
        out = {}
        units = {"asym": 1e6, "k2": G0 * 1e3, "D1": np.degrees(G0)}
        for key, wpow in (("asym", 2), ("k2", 4), ("D1", 2)):
            rec, tru = self.per_load[key], self.truth_per_load[key]
            if key == "D1":
                rec = np.moveaxis(np.diagonal(rec, axis1=1, axis2=2), 1, 2)  # (P, 3, L)
                tru = np.moveaxis(np.diagonal(tru, axis1=1, axis2=2), 1, 2)
            row = {"recovered_per_g": [], "truth_per_g": [], "recovered_rel_per_g": [], "truth_rel_per_g": []}
            for a in range(3):
                x = np.broadcast_to(self.loads_g, rec[:, a, :].shape).ravel()
                sw = x ** (wpow / 2)  # sqrt of the weight
                fits = []
                for v in (rec[:, a, :].ravel(), tru[:, a, :].ravel()):
                    (slope, icpt), *_ = np.linalg.lstsq(np.column_stack([x, np.ones_like(x)]) * sw[:, None],
                                                        v * sw, rcond=None)
                    fits.append(slope)
                t1 = float(np.mean(tru[:, a, 0]) - fits[1] * (self.loads_g[0] - 1.0))  # truth at 1 g
                row["recovered_per_g"].append(float(fits[0] * units[key]))
                row["truth_per_g"].append(float(fits[1] * units[key]))
                row["recovered_rel_per_g"].append(float(fits[0] / t1))
                row["truth_rel_per_g"].append(float(fits[1] / t1))
            out[key] = row
        return out


def _half_sums(y, A, A0, dt, n_per, n_bands):
    """Per recorded cycle pulse sums over the positive / negative half periods and, for the even terms, over
    ``n_bands`` bands of |A| (equal phase widths within each quarter period, both halves together).

    y (N,k), A (N,) [m/s^2] ruler acceleration. Returns dict of arrays: S_pos, S_neg (C,k), A_pos, A_neg, T_pos,
    T_neg (C,); S_band (B,k), T_band, U_band (Σ|A| dt), Q_band (Σ A² dt), A_band (Σ A dt) (B,), summed over cycles.
    """
    c = A.size // n_per
    sl = slice(0, c * n_per)
    Ar = A[sl].reshape(c, n_per)
    yr = y[sl].reshape(c, n_per, -1)
    out = {}
    for name, m in (("pos", Ar > 0), ("neg", Ar < 0)):
        out["S_" + name] = np.einsum("cn,cnk->ck", m.astype(float), yr) * dt
        out["A_" + name] = (m * Ar).sum(axis=1) * dt
        out["T_" + name] = m.sum(axis=1) * dt
    edges = np.sin(0.5 * np.pi * np.arange(n_bands + 1) / n_bands) * A0
    edges[-1] = np.inf
    band = np.clip(np.searchsorted(edges, np.abs(Ar), side="right") - 1, 0, n_bands - 1)
    for key in ("S_band", "T_band", "U_band", "Q_band", "A_band"):
        out[key] = []
    for b in range(n_bands):
        m = band == b
        out["S_band"].append(np.einsum("cn,cnk->k", m.astype(float), yr) * dt)
        out["T_band"].append(m.sum() * dt)
        out["U_band"].append((m * np.abs(Ar)).sum() * dt)
        out["Q_band"].append((m * Ar**2).sum() * dt)
        out["A_band"].append((m * Ar).sum() * dt)
    for key in ("S_band", "T_band", "U_band", "Q_band", "A_band"):
        out[key] = np.asarray(out[key])
    return out


def _run_load(unit, rng, p_on, axis, up, A0, rig, noise=True):
    """Simulate rest + one load; return (bias (6,), sums dict for gyro and accel)."""
    fs = unit.grade.sample_rate_hz
    dt = 1.0 / fs
    w = np.sqrt(A0 / rig.crank_m)
    period = 2 * np.pi / w
    n_per = int(round(period * fs))
    w = 2 * np.pi / (n_per * dt)  # the crank speed set so a cycle is a whole number of samples
    n_rest = int(round(rig.rest_s * fs))
    n_run = (rig.cycles + 1) * n_per
    t = np.arange(n_rest + n_run) * dt
    tt = np.clip(t - n_rest * dt, 0.0, None)
    A = np.where(t >= n_rest * dt, -A0 * np.sin(w * tt), 0.0)
    f = np.zeros((t.size, 3))
    f[:, axis] = A
    f[:, up] = G0
    s = simulate_imu(unit, t, np.zeros((t.size, 3)), f, np.full((t.size, 6), 25.0), rng, power_on=p_on,
                     noise=noise)
    bias = np.hstack([s.gyro[:n_rest].mean(axis=0), s.accel[:n_rest].mean(axis=0)])
    k0 = n_rest + n_per  # the first cycle is discarded
    y = np.hstack([s.gyro[k0:], s.accel[k0:]])
    sums = _half_sums(y, A[k0:], A0, dt, n_per, rig.bands)
    return bias, sums


def _unit_at_load(unit: ImuUnit, dep: LoadDependence, gl: float, eps) -> tuple:
    """(unit with the load-dependent Ka, K2, D1 at peak load gl [g], (Ka, K2, D1)); eps: the power-on draws."""
    x = gl - 1.0
    ka = np.asarray(unit.accel.asym, float) * (1 + dep.asym_per_g * x) * (1 + dep.power_on_rel * eps[0])
    k2 = np.asarray(unit.accel.k2, float) * (1 + dep.k2_per_g * x) * (1 + dep.power_on_rel * eps[1])
    d1 = np.asarray(unit.gyro.g_sens, float) * (1 + dep.d1_per_g * x) * (1 + dep.power_on_rel * eps[2])
    u = replace(unit, accel=replace(unit.accel, asym=ka, k2=k2), gyro=replace(unit.gyro, g_sens=d1))
    return u, (ka, k2, d1)


def calibrate_overload(unit: ImuUnit, rng: np.random.Generator, rig: OverloadRig = OverloadRig(), *,
                       noise: bool = True, dependence: LoadDependence | None = None) -> OverloadResult:
    """Simulate the overload table on ``unit`` and recover Ka, K2 (accelerometers) and D1 (gyros).

    noise=False: deterministic sensor output and no power-on draw (a check of the estimators' algebra).
    dependence: a :class:`LoadDependence` truth model (None: constant coefficients); its power-on draws come
    from a generator seeded from ``rng`` (with noise=False none are drawn: the load trend alone).
    """
    t0 = time.perf_counter()
    loads = np.asarray(rig.loads_g, float)
    P, L = rig.power_ons, loads.size
    asym, k2, K1 = np.zeros((P, 3, L)), np.zeros((P, 3, L)), np.zeros((P, 3, L))
    D1 = np.zeros((P, 3, 3, L))
    tpl = None
    if dependence is not None:
        dep_rng = np.random.default_rng(rng.integers(2**63))
        tpl = {"asym": np.zeros((P, 3, L)), "k2": np.zeros((P, 3, L)), "D1": np.zeros((P, 3, 3, L))}
    rows = {a: [] for a in range(3)}  # joint least squares of (Ka/2, K2) per accelerometer axis
    for p in range(P):
        p_on = draw_power_on(unit, rng) if noise else zero_power_on()
        if dependence is not None:
            eps = ((dep_rng.standard_normal(3), dep_rng.standard_normal(3), dep_rng.standard_normal((3, 3)))
                   if noise else (np.zeros(3), np.zeros(3), np.zeros((3, 3))))
        for axis, up in MOUNTINGS:
            for li, gl in enumerate(loads):
                u = unit
                if dependence is not None:
                    u, (ka_t, k2_t, d1_t) = _unit_at_load(unit, dependence, gl, eps)
                    tpl["asym"][p, axis, li], tpl["k2"][p, axis, li] = ka_t[axis], k2_t[axis]
                    tpl["D1"][p, :, axis, li] = d1_t[:, axis]
                bias, s = _run_load(u, rng, p_on, axis, up, gl * G0, rig, noise)
                dA = s["A_pos"].sum() - s["A_neg"].sum()  # Σ over cycles of (V_max - V_min) - (V_min - V_max)
                dS = s["S_pos"].sum(axis=0) - s["S_neg"].sum(axis=0)
                D1[p, :, axis, li] = (dS[:3] - bias[:3] * (s["T_pos"].sum() - s["T_neg"].sum())) / dA
                K1[p, axis, li] = (dS[3 + axis] - bias[3 + axis] * (s["T_pos"].sum() - s["T_neg"].sum())) / dA
                # even part per |A| band: S_band - K1 Σ A dt = b T + (Ka/2) Σ|A| dt + K2 Σ A² dt; b, Ka, K2 by
                # least squares over the bands (b from the run itself: the rest's bias has drifted by then)
                e = s["S_band"][:, 3 + axis] - K1[p, axis, li] * s["A_band"]
                M = np.column_stack([s["T_band"], s["U_band"], s["Q_band"]])
                sc = np.abs(M).max(axis=0)
                sol, *_ = np.linalg.lstsq(M / sc, e, rcond=None)
                sol = sol / sc
                asym[p, axis, li], k2[p, axis, li] = 2.0 * sol[1], sol[2]
                rows[axis].append((M, e))
    ja, jk = np.zeros(3), np.zeros(3)
    for a in range(3):  # all loads and power-ons: shared Ka, K2, one bias per run
        runs = rows[a]
        nb = len(runs)
        M = np.zeros((sum(len(e) for _, e in runs), 2 + nb))
        r = np.concatenate([e for _, e in runs])
        i = 0
        for j, (Mj, ej) in enumerate(runs):
            M[i:i + len(ej), 0:2] = Mj[:, 1:]
            M[i:i + len(ej), 2 + j] = Mj[:, 0]
            i += len(ej)
        sc = np.abs(M).max(axis=0)
        sol, *_ = np.linalg.lstsq(M / sc, r, rcond=None)
        ja[a], jk[a] = 2.0 * sol[0] / sc[0], sol[1] / sc[1]
    joint = OverloadCoefficients(asym=ja, k2=jk, D1=D1.mean(axis=(0, 3)))
    return OverloadResult(loads_g=loads, per_load={"asym": asym, "k2": k2, "K1": K1, "D1": D1}, joint=joint,
                          truth=truth_coefficients(unit), runtime_s=time.perf_counter() - t0,
                          truth_per_load=tpl, dependence=dependence)


def compensate_overload(samples: ImuSamples, coeffs: OverloadCoefficients) -> ImuSamples:
    """Remove the dynamic terms from raw samples: accel ``f = y - (Ka/2)|f| - K2 f²`` (solved by fixed-point
    iteration), gyro -= D1 f (f [m/s^2]; the constant 1 g part this also removes from a unit at rest is
    what the filters' rest-window bias takes anyway)."""
    y = np.asarray(samples.accel, float)
    acc = y
    for _ in range(3):  # fixed point of acc = y - (Ka/2)|acc| - K2 acc² (one pass leaves 2 K2 f δ: 0.2 mg at 8 g)
        acc = y - 0.5 * coeffs.asym * np.abs(acc) - coeffs.k2 * acc**2
    gyro = np.asarray(samples.gyro, float) - acc @ np.asarray(coeffs.D1, float).T
    return ImuSamples(t=samples.t, gyro=gyro, accel=acc, temp_C=samples.temp_C)
