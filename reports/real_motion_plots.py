"""The filters on the real development files (:mod:`imutherm.studies.attitude.real_settings`): the figure beside the
study's simulated answer."""

from __future__ import annotations

import numpy as np


def real_motion_figure(fig, rs) -> None:
    """Two panels from a :class:`~imutherm.studies.attitude.real_settings.RealSettings`: (left) each filter's mean
    inclination RMS [deg] over the files at its library defaults, at its dev setting (tuned on all files) and
    cross-validated (each file scored by the setting tuned on the others); (right) each file's cross-validated RMS as a
    ratio to VQF's (tuned by the same procedure), log scale, with the issue's 2x line."""
    from imutherm.imu.filters.registry import color, linestyle, reference_filter

    e = rs.entries
    names = [n for n in e if "cv_mean" in e[n]]
    files = rs.meta.get("files", [])
    short = ["B" + f.split("_")[0] if f[:2].isdigit() else f.replace("Pendulum_Test", "").replace("_Trial1_Segment_", "/")
             for f in files]
    ax1 = fig.add_subplot(1, 2, 1)
    x = np.arange(len(names))
    for k, (key, lab, alpha) in enumerate((("defaults_mean", "library defaults", 0.35), ("dev_mean", "dev (fitted)", 0.6),
                                           ("cv_mean", "cross-validated", 1.0))):
        ax1.bar(x + (k - 1) * 0.27, [e[n][key] for n in names], 0.27, label=lab, alpha=alpha,
                color=[color(n) for n in names], edgecolor="k", linewidth=0.3)
    ax1.set_yscale("log")
    ax1.set_xticks(x, names, rotation=45, fontsize=7)
    ax1.set_ylabel("mean inclination RMS over the files [deg]", fontsize=7)
    ax1.legend(fontsize=6, loc="upper right")
    ax1.tick_params(labelsize=7)
    ax2 = fig.add_subplot(1, 2, 2)
    ref = reference_filter()  # the peer the others are set against
    vq = np.array(e[ref]["cv_rms"]) if ref in e else None
    if vq is not None:
        for n in names:
            if n == ref:
                continue
            ax2.plot(range(len(files)), np.array(e[n]["cv_rms"]) / vq, marker="o", ms=3, color=color(n),
                     linestyle=linestyle(n), label=n, linewidth=1)
        ax2.axhline(1.0, color="k", linewidth=0.8)
        ax2.axhline(2.0, color="k", linewidth=0.6, linestyle=":")
        ax2.set_yscale("log")
        ax2.set_ylabel("cross-validated RMS / VQF's (same procedure)", fontsize=7)
        ax2.set_xticks(range(len(files)), short, rotation=45, fontsize=7)
        ax2.legend(fontsize=6, ncol=2)
        ax2.tick_params(labelsize=7)
