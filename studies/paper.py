"""The source paper's figures (Liu et al. 2012), read from ``paper_targets.toml`` beside this module.

Only what the paper's text states; every comparison in the studies and reports
reads it from here, so the numbers have one home and one named source.
"""

from __future__ import annotations

import sys
from functools import lru_cache
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

PAPER_FILE = Path(__file__).with_name("paper_targets.toml")
SOURCE = "Liu et al. 2012 (NUAA), figures stated in its text: studies/paper_targets.toml"


@lru_cache(maxsize=1)
def load_paper() -> dict:
    """The paper's figures as a dict (temperatures in °C, rises in K, times in s, angles in deg)."""
    with open(PAPER_FILE, "rb") as fh:
        data = tomllib.load(fh)
    data["source"] = SOURCE
    return data


def paper_scheme_figures() -> dict:
    """Per scheme: the paper's simulated max rise [K] and measured rise / settle time where stated."""
    p = load_paper()
    sim, meas = p["thermal"]["simulated"], p["thermal"]["measured"]
    return {
        "air": {"simulated_max_rise_K": sim["scheme1_air_max_rise_K"],
                "measured_rise_K": f">= {meas['no_grease_rise_K_at_least']:g}",
                "measured_rise_lower_K": meas["no_grease_rise_K_at_least"],
                "measured_settle_s": meas["no_grease_near_steady_s"]},
        "grease": {"simulated_max_rise_K": sim["scheme2_grease_max_rise_K"],
                   "measured_rise_K": f"<= {meas['grease_rise_K_at_most']:g}",
                   "measured_rise_upper_K": meas["grease_rise_K_at_most"],
                   "measured_settle_s": meas["grease_steady_s"]},
        "potted": {"simulated_max_rise_K": sim["scheme3_potted_max_rise_K"]},
    }
