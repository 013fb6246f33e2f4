"""Observers of a transient: what is recorded of each accepted step.

The probe history (``ProbeHistory``), whole fields at requested times (``SavedFields``), the energy
account integrated with each scheme's own weights (``EnergyAccount``) and the settle stop
(``SettleWatch``); each takes the steps (``imutherm.thermal.stepping.AcceptedStep``) one at a time.
"""

from __future__ import annotations

import numpy as np

from imutherm.thermal.assembly import Assembly
from imutherm.thermal.stepping import AcceptedStep

class ProbeHistory:
    """Observer: the step times and the probe temperatures at each."""

    def __init__(self, P, T0):
        self.P = P
        self.times = [0.0]
        self.probes = [P @ T0]

    def observe(self, st: AcceptedStep):
        self.times.append(st.tb)
        self.probes.append(self.P @ st.T)

    def arrays(self):
        times = np.array(self.times)
        return times, np.array(self.probes).reshape(len(times), -1)


class SavedFields:
    """Observer: whole fields at the requested times (linear in time within a step)."""

    def __init__(self, sv, T0):
        self.sv = sv
        self.saved = []
        while len(self.saved) < sv.size and sv[len(self.saved)] <= 0.0:
            self.saved.append(T0.copy())

    def observe(self, st: AcceptedStep):
        sv, ta, tb = self.sv, st.ta, st.tb
        while len(self.saved) < sv.size and sv[len(self.saved)] <= tb * (1 + 1e-12):
            w = min(max((sv[len(self.saved)] - ta) / (tb - ta), 0.0), 1.0)
            self.saved.append(st.T_prev + w * (st.T - st.T_prev))

    def array(self, n_nodes):
        return np.array(self.saved).reshape(len(self.saved), n_nodes)


class EnergyAccount:
    """Observer: energy put in and let out [J], each integrated with the scheme's own weights."""

    def __init__(self, asm: Assembly):
        self.asm = asm
        self.sumFq, self.flux_in = float(asm.F_q.sum()), asm.flux_in_W
        self.E_in = self.E_out = 0.0

    def observe(self, st: AcceptedStep):
        self.E_in += st.h * (st.power_mean * self.sumFq + self.flux_in)
        self.E_out += st.h * st.heat_out_W
        if st.fixed_in_J is not None:
            self.E_out -= st.fixed_in_J

    def close(self, T_start, T):
        """(energy stored [J], relative balance error [-]) from ``T_start`` to ``T``."""
        cap = np.asarray(self.asm.pattern.csr(self.asm.M_data).sum(axis=1)).ravel()   # 1^T M (symmetric)
        E_stored = float(cap @ (T - T_start))
        denom = max(abs(self.E_in), abs(E_stored) + abs(self.E_out), 1e-300)
        return E_stored, abs(self.E_in - E_stored - self.E_out) / denom


class SettleWatch:
    """The settle stop: True once every probe has passed 95 % of its rise and is within ``fraction`` of it."""

    def __init__(self, final, fraction, history: ProbeHistory):
        self.final, self.fraction, self.history = final, fraction, history
        self.p0 = history.probes[0]
        self.rise = final - self.p0
        self.passed95 = self.rise == 0

    def observe(self, st: AcceptedStep) -> bool:
        p = self.history.probes[-1]
        nz = self.rise != 0
        frac = np.ones_like(self.rise)
        frac[nz] = (p[nz] - self.p0[nz]) / self.rise[nz]
        self.passed95 |= frac >= 0.95
        gap = np.abs(self.final - p)
        return bool(np.all(self.passed95) and np.all(gap <= self.fraction * np.abs(self.rise)))
