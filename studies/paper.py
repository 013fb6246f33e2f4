"""The reference data a layout declares (``[reference_data]``, :mod:`imutherm.reference_data`), ready to set
beside the model: the paper's figures (Liu et al. 2012, ``paper_targets.toml`` beside this module) for the layout
that declares them, and a user's bench readings (measured CSVs) against the model at the same site and time.

A layout that declares nothing gets None from both: no paper's figures appear for a user's own unit.
"""

from __future__ import annotations

import sys
from functools import lru_cache
from pathlib import Path

import numpy as np

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

PAPER_FILE = Path(__file__).with_name("paper_targets.toml")
SOURCE = "Liu et al. 2012 (NUAA), figures stated in its text: studies/paper_targets.toml"


@lru_cache(maxsize=4)
def load_paper(path: str | None = None) -> dict:
    """A paper's figures as a dict (temperatures in °C, rises in K, times in s, angles in deg); default: Liu et
    al. 2012's digest."""
    with open(path or PAPER_FILE, "rb") as fh:
        data = tomllib.load(fh)
    data["source"] = SOURCE if path is None or Path(path).resolve() == PAPER_FILE.resolve() else str(path)
    return data


def layout_paper(layout) -> dict | None:
    """The paper figures ``layout`` declares (``[reference_data] paper_figures``), or None."""
    ref = getattr(layout, "reference_data", None)
    if ref is None or ref.paper_figures is None:
        return None
    return load_paper(ref.paper_figures)


def paper_scheme_figures(paper: dict | None = None) -> dict:
    """Per scheme: the paper's simulated max rise [K] and measured rise / settle time where stated."""
    p = paper or load_paper()
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


def check_bench(layout) -> list:
    """Read and check every bench file the layout declares (its sites and schemes); InputError naming the file and
    line on a bad one. Returns the runs."""
    from imutherm.measured import read_measured

    ref = getattr(layout, "reference_data", None)
    sites, schemes = [s.name for s in layout.sites], list(layout.schemes)
    return [read_measured(p, sites=sites, schemes=schemes) for p in (ref.measured if ref is not None else ())]


def bench_comparison(layout, curves: dict) -> dict | None:
    """The layout's bench readings (``[reference_data] measured``) beside the model, or None if it declares none.

    curves : scheme -> (site names, times [s] (inf: steady only), temperatures [degC] (n, m)) of the model's
        power-on transient at the layout's ambient; the last row is taken as the steady state.
    Returns ``{"source", "files", "rows": [{file, scheme, site, time_s, measured_K, model_K, difference_K,
    note}]}``, rises over each run's own ambient [K]; readings of a scheme the model did not run are left out
    (said in ``not_compared``).
    """
    ref = getattr(layout, "reference_data", None)
    if ref is None or not ref.measured:
        return None
    rows, skipped = [], []
    for path, run in zip(ref.measured, check_bench(layout)):
        if run.scheme not in curves:
            skipped.append(f"{run.name} (scheme {run.scheme} not run)")
            continue
        names, t, T = curves[run.scheme]
        t, T = np.asarray(t, float), np.asarray(T, float)
        rise = T - layout.ambient_C
        for i, time_s in enumerate(run.times_s):
            for j, site in enumerate(run.sites):
                meas = run.rise_K[i, j]
                if not np.isfinite(meas) or site not in names:
                    continue
                k = list(names).index(site)
                notes = []
                if not np.isfinite(time_s) or time_s > t[-1]:
                    model = rise[-1, k]
                    if np.isfinite(time_s):
                        notes.append(f"past the model's curve ({t[-1]:.0f} s, settled): its last value")
                else:
                    model = float(np.interp(time_s, t, rise[:, k]))
                if run.power_scale != 1.0:
                    model *= run.power_scale
                    notes.append(f"model scaled by the run's power_scale {run.power_scale:g} (rise taken as "
                                 "linear in power, approximate)")
                if abs(run.ambient_C - layout.ambient_C) > 5.0:
                    notes.append(f"bench at {run.ambient_C:g} C, model at {layout.ambient_C:g} C ambient")
                rows.append({"file": Path(path).name, "scheme": run.scheme, "site": site,
                             "time_s": float(time_s) if np.isfinite(time_s) else None,
                             "probe": run.probe, "measured_K": float(meas), "model_K": float(model),
                             "difference_K": float(model - meas), "note": "; ".join(notes)})
    return {"source": ref.source, "files": [Path(p).name for p in ref.measured], "rows": rows,
            **({"not_compared": skipped} if skipped else {})}


def bench_lines(bench: dict | None) -> list:
    """The bench comparison as printed lines (none without bench readings)."""
    if not bench:
        return []
    rows = bench["rows"]
    out = [f"your reference data ({bench['source']}): {len(rows)} readings beside the model, rises over ambient [K]"]
    for r in rows:
        when = "steady" if r["time_s"] is None else f"{r['time_s']:g} s"
        out.append(f"  {r['scheme']:<8} {r['site']:<10} {when:>8}  measured {r['measured_K']:6.2f}  model "
                   f"{r['model_K']:6.2f}  model - measured {r['difference_K']:+6.2f}"
                   + (f"  ({r['note']})" if r["note"] else ""))
    if rows:
        d = np.array([r["difference_K"] for r in rows])
        out.append(f"  RMS difference {np.sqrt(np.mean(d ** 2)):.2f} K, mean {d.mean():+.2f} K over {len(rows)} "
                   "readings")
    for s in bench.get("not_compared", []):
        out.append(f"  not compared: {s}")
    return out
