"""Figure of ``imutherm calibrate``: residual vs temperature, uncompensated / conventional / improved.

Drawn from the ``evaluation`` block of ``calibration.json`` only (a dict), never from live objects.
"""

from __future__ import annotations

import os

import matplotlib.pyplot as plt
import numpy as np

_STYLE = {"none": ("uncompensated", "tab:gray", "x"),
          "conventional": ("conventional (eq. 1, 2nd mounting)", "tab:red", "o"),
          "improved": ("improved (eq. 2-3)", "tab:blue", "s")}


def plot_calibration_residuals(result: dict, path: str | os.PathLike) -> None:
    """Write a two-panel PNG: max |residual| per test run vs temperature [°C], accel [mg] and gyro [°/s].

    Parameters
    ----------
    result : dict   the content of calibration.json (needs ``evaluation`` with ``temp_C``,
                    ``accel_residual_mg`` and ``gyro_residual_dps`` per method; optional ``paper``)
    path : str | PathLike  output PNG
    """
    ev = result["evaluation"]
    T = np.asarray(ev["temp_C"], float)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    for ax, key, unit in ((axes[0], "accel_residual_mg", "mg"), (axes[1], "gyro_residual_dps", "°/s")):
        for meth, (label, color, marker) in _STYLE.items():
            r = np.abs(np.asarray(ev[key][meth], float)).max(axis=1)
            ax.semilogy(T, np.maximum(r, 1e-6), marker, ms=3.5, color=color, alpha=0.6, ls="none",
                        label=f"{label}: max {r.max():.3g} {unit}")
        ax.set_xlabel("soak temperature [°C]")
        ax.set_ylabel(f"max |residual| over axes [{unit}]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="lower right")
    paper = result.get("paper", {})
    if paper:
        for v, ls in ((paper.get("conventional_max_residual_mg"), "--"), (paper.get("improved_max_residual_mg"), ":")):
            if v:
                axes[0].axhline(v, color="k", ls=ls, lw=0.8)
        axes[0].text(0.01, 0.98, "paper: 30 mg (- -) / 5 mg (··)", transform=axes[0].transAxes, va="top", fontsize=8)
    axes[0].set_title(f"accelerometers ({result.get('grade', '?')}, seed {result.get('seed', '?')})")
    axes[1].set_title(f"gyros (oven mounting {result.get('oven_mount_deg', '?')}°)")
    fig.savefig(path, dpi=120)
    plt.close(fig)
