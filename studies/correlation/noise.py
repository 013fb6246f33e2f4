"""Noise statistics of measured runs (probe noise, effective sample size) and the localisation of the
nominal model's residuals (per site and phase, lag, physical fingerprints).
"""

from __future__ import annotations

import math

import numpy as np

from imutherm.geometry.build import MM
from imutherm.measured import MeasuredRun
from imutherm.studies.correlation.discrepancy import term_curve
from imutherm.studies.correlation.forward_model import ForwardModel


#: noise assumed for sparse series (fewer than 8 points) where it cannot be estimated [K]
SPARSE_NOISE_K = 0.5


#: the noise estimate uses the second differences' spectrum above this angular frequency [rad/sample]
#: (where the second difference passes a white noise at >= its own power; a smooth residual lives below)
NOISE_OMEGA_MIN = math.pi / 3


def noise_sigma(run: MeasuredRun) -> float:
    """Probe noise [K] of a run, robust to smooth and periodic residuals (median over its dense series).

    Per series (>= 8 finite readings): the second differences d of the readings (a smooth curve's are
    small; a power-on kink or a step gives a few large ones), their Hann-windowed periodogram divided by
    the second difference's gain |2 - 2 cos ω|² at the frequencies above :data:`NOISE_OMEGA_MIN`, and
    the median of these ordinates over ln 2 (a white noise's normalised ordinates are σ² times an
    exponential variable, whose median is ln 2): a cycle, however it is sampled, is a peak in one or two
    ordinates and moves a median little, where it moved the MAD of the second differences by its whole
    amplitude (the last campaign: a 203 s cycle sampled ~5 times per period counted as noise, 0.10 K
    against 0.05 K). Series with fewer than 8 readings: :data:`SPARSE_NOISE_K` (stated, not estimated).
    The readings are taken as evenly spaced (the estimate is per reading).
    """
    sig = []
    for j in range(len(run.sites)):
        y = run.values_C[:, j]
        t = run.times_s
        ok = np.isfinite(y) & np.isfinite(t)
        if ok.sum() < 8:
            continue
        sig.append(_noise_of_series(y[ok]))
    return float(np.median(sig)) if sig else SPARSE_NOISE_K


def _noise_of_series(y: np.ndarray) -> float:
    d = np.diff(np.asarray(y, float), 2)
    n = len(d)
    w = np.hanning(n + 2)[1:-1]
    X = np.fft.rfft((d - np.median(d)) * w)
    P = np.abs(X) ** 2 / float(w @ w)
    om = 2 * np.pi * np.arange(len(P)) / n
    sel = (om > NOISE_OMEGA_MIN) & (np.arange(len(P)) < len(P) - (n % 2 == 0))  # no Nyquist bin (real)
    gain = (2 - 2 * np.cos(om[sel])) ** 2
    return float(math.sqrt(np.median(P[sel] / gain) / math.log(2)))


def n_eff_ratio(fwd: ForwardModel, values: dict, disc=None, coefs=None) -> float:
    """n_eff / n from the lag-1 autocorrelation of the residuals of each series (>= 4 points); with a
    discrepancy term (``disc`` and its ``coefs``), of the residuals it leaves."""
    n_tot, ne_tot = 0, 0.0
    for i, run in enumerate(fwd.runs):
        r = fwd.rise(i, values) - run.rise_K - term_curve(disc, coefs or {}, i, run)
        for j in range(len(run.sites)):
            x = r[np.isfinite(r[:, j]) & np.isfinite(run.times_s), j]
            n = len(x)
            if n == 0:
                continue
            n_tot += n
            if n <= 3:
                ne_tot += n
                continue
            x = x - x.mean()
            den = float(x @ x)
            rho = float(x[1:] @ x[:-1]) / den if den > 0 else 0.0
            rho = min(max(rho, 0.0), 0.99)
            ne_tot += max(n * (1 - rho) / (1 + rho), 1.0)
    return ne_tot / n_tot if n_tot else 1.0


def _phase_stats(r: np.ndarray, t: np.ndarray, t63: float, t95: float) -> dict:
    out = {}
    for phase, sel in (("rise", t <= t63), ("plateau", t >= t95)):
        x = r[sel & np.isfinite(r)]
        out[phase] = {"n": int(len(x)), "mean_K": float(x.mean()) if len(x) else None,
                      "rms_K": float(np.sqrt(np.mean(x**2))) if len(x) else None}
    return out


def _lag_s(t, model, meas) -> float | None:
    """Shift [s] of the model curve that best matches the measured one (positive: measured lags)."""
    ok = np.isfinite(t) & np.isfinite(meas)
    if ok.sum() < 6:
        return None
    tt, mm, yy = t[ok], model[ok], meas[ok]
    shifts = np.linspace(-0.3 * tt.max(), 0.3 * tt.max(), 121)
    err = [np.mean((np.interp(tt - s, tt, mm, left=0.0) - yy) ** 2) for s in shifts]
    return float(shifts[int(np.argmin(err))])


def localise(fwd: ForwardModel, values: dict) -> tuple:
    """Per run and site: residual mean/RMS/max, per phase, lag; and the fingerprint correlations."""
    out, rows = {}, []
    for i, run in enumerate(fwd.runs):
        rom = fwd.roms[(run.scheme, run.ambient_C)]
        model = fwd.rise(i, values)
        r = model - run.rise_K
        geo = fwd.geometries[run.scheme]
        z0 = geo.outer[0][2]
        site_stats = {}
        for j, s in enumerate(run.sites):
            x = r[:, j]
            ok = np.isfinite(x)
            if not ok.any():
                continue
            steady = float(rom.nominal_rise_K[rom.site_names.index(s)])
            t = run.times_s
            fine = np.geomspace(1.0, 2.0e4, 400)
            curve = fwd.rise(i, values, fine)[:, j]
            fin = curve[-1] if curve[-1] > 0 else steady
            t63 = float(np.interp(0.632 * fin, curve, fine)) if fin > 0 else math.nan
            t95 = float(np.interp(0.95 * fin, curve, fine)) if fin > 0 else math.nan
            site_stats[s] = {"n": int(ok.sum()), "mean_K": float(x[ok].mean()),
                             "rms_K": float(np.sqrt(np.mean(x[ok] ** 2))), "max_abs_K": float(np.abs(x[ok]).max()),
                             "phases": _phase_stats(x, t, t63, t95), "lag_s": _lag_s(t, model[:, j], run.rise_K[:, j]),
                             "model_t63_s": t63, "model_t95_s": t95}
            pos = np.asarray(geo.sites[s])
            Tm = model[ok, j] + run.ambient_C + 273.15
            Ta = run.ambient_C + 273.15
            tt = np.where(np.isfinite(t[ok]), t[ok], 1e9)
            dTdt = np.gradient(model[ok, j], tt) if ok.sum() > 1 else np.zeros(ok.sum())
            for k in range(int(ok.sum())):
                rows.append((x[ok][k], model[ok, j][k], Tm[k] ** 4 - Ta**4, dTdt[k], (pos[2] - z0) / MM))
        out[run.name] = site_stats
    fp = {}
    if len(rows) >= 3:
        R = np.array(rows)
        for col, name in ((1, "rise (power map, dT)"), (2, "T^4 - T_amb^4 (radiation)"),
                          (3, "dT/dt (heat capacity, lag)"), (4, "height above the mount face")):
            a, b = R[:, 0], R[:, col]
            fp[name] = float(np.corrcoef(a, b)[0, 1]) if a.std() > 0 and b.std() > 0 else None
    return out, fp
