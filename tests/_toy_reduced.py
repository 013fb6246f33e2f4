"""A toy stand-in for the reduced models: closed-form site rises whose knobs act linearly on each site's gain
and time constant, so the correlation's selection logic can be tested in seconds (no FEM)."""

import numpy as np

from imutherm.unit import knobs

SITES = ("tp1", "tp2", "tp3", "gyro_x", "gyro_y", "gyro_z")
#: nominal steady rise [K] and time constant [s] of each site, per scheme
BASE = {"air": (np.array([17.0, 15.0, 12.0, 9.0, 8.5, 8.0]), np.array([90.0, 110.0, 130.0, 160.0, 170.0, 180.0])),
        "grease": (np.array([10.0, 8.0, 7.0, 5.0, 4.8, 4.5]), np.array([70.0, 80.0, 90.0, 110.0, 115.0, 120.0]))}
#: each effect's change of the sites' gain per unit of (parameter - reference) [K / unit], per scheme
PATTERN = {
    "power@reg_5v": {"air": np.array([14.0, 6.0, 3.0, 2.0, 1.5, 1.0]), "grease": np.array([8.0, 3.0, 1.5, 1.0, 0.8, 0.5])},
    "power@processor": {"air": np.array([3.0, 12.0, 4.0, 2.5, 2.0, 1.0]), "grease": np.array([1.5, 7.0, 2.0, 1.2, 1.0, 0.6])},
    "cavity_emissivity": {"air": -np.array([6.0, 5.5, 5.0, 3.0, 3.0, 3.0]), "grease": -np.array([1.0, 1.0, 1.0, 0.5, 0.5, 0.5])},
    # a poor bond line (grease only): per unit of log(1000 / h)
    "contact@bond": {"air": np.zeros(6), "grease": np.array([0.5, 0.8, 0.6, 1.2, 1.1, 1.0])},
}
REF = {"power@reg_5v": 0.0, "power@processor": 0.0, "cavity_emissivity": 0.77, "contact@bond": 1000.0}


class ToyReduced:
    """``rise(values, times, drift)`` [K] (len(times), 6) like :class:`imutherm.thermal.reduced.ReducedModel`."""

    def __init__(self, scheme: str):
        self.scheme = scheme
        self.site_names = SITES
        ks = [k for k, _ in knobs.RETUNE] + [knobs.effect_knob(n) for n in PATTERN]
        self.knobs = {k.name: k for k in ks}
        self.nominal_rise_K = BASE[scheme][0].copy()
        self.basis_size, self.unknowns, self.build_s, self.solves = 0, 0, 0.0, 0

    def gain_tau(self, values: dict):
        dT, tau = BASE[self.scheme]
        g = dT * values.get("power_scale", 1.0) * (1 + 0.08 * np.log(500.0 / values.get("mount_h_W_m2K", 500.0)))
        g = g * (1 + 0.2 * (17.7 / values.get("k_board_W_mK", 17.7) - 1) * np.linspace(1, 0.2, 6))
        g = g / (1 + 0.05 * (values.get("convection_scale", 1.0) - 1))
        for name, pat in PATTERN.items():
            if name in values:
                x = values[name]
                d = np.log(REF[name] / x) if name.startswith("contact@") else x - REF[name]
                g = g + pat[self.scheme] * d
        return g, tau * (g / dT) ** 0.5

    def rise(self, values: dict, times, drift_K_s: float = 0.0):
        t = np.asarray(times, float)
        g, tau = self.gain_tau(values)
        out = np.where(np.isfinite(t)[:, None], g * -np.expm1(-np.where(np.isfinite(t), t, 0)[:, None] / tau), g)
        return out + drift_K_s * np.where(np.isfinite(t), t, 0.0)[:, None]


def toy_models():
    """A :class:`~imutherm.studies.correlation.Models` of the toy for air and grease at 70 C."""
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.layout import load_layout
    from imutherm.studies.correlation import Models
    lay = load_layout(None)
    geos = {s: build_geometry(lay, s) for s in ("air", "grease")}
    return Models({(s, 70.0): ToyReduced(s) for s in geos}, geos, 0.0, {(s, 70.0): g for s, g in geos.items()})


def toy_runs(values: dict, rng, extra=None, samples: int = 40, noise_K: float = 0.05):
    """Measured runs of the toy (air and grease at 70 C, 1500 s) with ``values`` and probe noise;
    ``extra(scheme, t)`` -> (n, 6) [K] added (a model-form error)."""
    from imutherm.measured import MeasuredRun
    t = np.linspace(0.0, 1500.0, samples)
    runs = []
    for s in ("air", "grease"):
        y = ToyReduced(s).rise(values, t)
        if extra is not None:
            y = y + extra(s, t)
        v = 70.0 + y + rng.normal(0.0, noise_K, y.shape)
        runs.append(MeasuredRun(f"{s}.csv", s, 70.0, 1.0, 0.0, "die", SITES, t, v, tuple(range(samples))))
    return runs
