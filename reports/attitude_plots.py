"""Roll / pitch error vs time per filter, manoeuvre segments shaded (from attitude_series.npz)."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from imutherm.imu.filters.registry import color as filter_color


def _wrap_deg(a):
    return (np.asarray(a) + 180.0) % 360.0 - 180.0


def plot_attitude(series_path, png_path, *, ylim_deg: float | None = None) -> Path:
    """Draw ``attitude.png`` from ``attitude_series.npz`` (written by ``imutherm attitude``).

    series_path : npz with t [s], phase, truth_roll_deg / truth_pitch_deg [deg] and
    <filter>_roll_deg / <filter>_pitch_deg [deg]; png_path : output; ylim_deg [deg]
    symmetric y limit (None: from the data, at most 15°).
    """
    s = np.load(series_path, allow_pickle=False)
    t = s["t"]
    names = [k[: -len("_roll_deg")] for k in s.files if k.endswith("_roll_deg") and not k.startswith("truth")]
    manoeuvre = s["phase"] == "manoeuvre"
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(11, 6.5))
    lim = 0.0
    for ax, key in zip(axes, ("roll", "pitch")):
        for n in names:
            err = _wrap_deg(s[f"{n}_{key}_deg"] - s[f"truth_{key}_deg"])
            lim = max(lim, float(np.percentile(np.abs(err), 99)))
            rms = float(np.sqrt(np.mean(err**2)))
            ax.plot(t, err, lw=0.7, color=filter_color(n), label=f"{n} (rms {rms:.2f}°)")
        # shade manoeuvre spans
        edges = np.flatnonzero(np.diff(np.r_[0, manoeuvre.astype(int), 0]))
        for a, b in zip(edges[::2], edges[1::2]):
            ax.axvspan(t[a], t[min(b, len(t) - 1)], color="orange", alpha=0.12, lw=0)
        ax.set_ylabel(f"{key} error [deg]")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize=8, ncol=2)
    y = ylim_deg if ylim_deg is not None else min(15.0, max(1.0, 1.1 * lim))
    for ax in axes:
        ax.set_ylim(-y, y)
    axes[-1].set_xlabel("time [s]  (shaded: manoeuvre segments)")
    fig.suptitle("Attitude error per filter (first seed)")
    fig.tight_layout()
    png_path = Path(png_path)
    fig.savefig(png_path, dpi=110)
    plt.close(fig)
    return png_path
