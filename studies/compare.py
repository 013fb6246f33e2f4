"""The main job: the cooling schemes of a layout side by side (steady + power-on transient).

``compare_schemes`` runs :func:`imutherm.studies.thermal.thermal_study.run_scheme` for
each scheme and collects what the comparison report needs: the summary of each
run, the site curves, and a temperature map in the main board's mid-plane.
``write_comparison`` writes the result files the report is drawn from, with the reference data the layout
declares (the paper's figures for the reference unit; a user's bench readings; none for an imported unit).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from imutherm import InputError
from imutherm.io import write_json
from imutherm.geometry.layout import load_layout
from imutherm.site_table import write_site_table
from imutherm.studies.thermal.thermal_study import (SchemeResult, board_plane_map, model_curves, probe_table,
                                            result_summary)

def paper_thermal(layout) -> dict | None:
    """The thermal figures of the paper ``layout`` declares (``[reference_data] paper_figures``; the reference
    unit: Liu et al. 2012) in the shape the thermal comparison files use, or None: a layout that declares no
    paper (an imported unit) is set beside none."""
    from imutherm.studies.paper import layout_paper

    p = layout_paper(layout)
    if p is None:
        return None
    sim, meas = p["thermal"]["simulated"], p["thermal"]["measured"]
    return {"source": p["source"],
            "simulated_max_rise_K": {"air": sim["scheme1_air_max_rise_K"], "grease": sim["scheme2_grease_max_rise_K"],
                                     "potted": sim["scheme3_potted_max_rise_K"]},
            "measured": {"air": {"rise_K_at_least": meas["no_grease_rise_K_at_least"],
                                 "near_steady_s": meas["no_grease_near_steady_s"]},
                         "grease": {"rise_K_at_most": meas["grease_rise_K_at_most"], "steady_s": meas["grease_steady_s"]}}}


#: column labels of the thermal comparison table (line breaks where the report wraps them); the two paper
#: columns only for a layout that declares the paper's figures
TABLE_COLUMNS = ("scheme", "steady max\nrise [K]", "paper sim.\n[K]", "hottest part", "tp1\n[K]", "tp2\n[K]",
                 "tp3\n[K]", "gyro\nspread [K]", "accel\nspread [K]", "t95 tp1\n[s]", "paper meas.\nsettle [s]",
                 "energy\nbalance")
_PAPER_COLUMNS = (2, 10)


def thermal_table(data: dict) -> tuple[list[str], list[list[str]]]:
    """(columns, rows) of the thermal comparison, one formatted row per scheme, built once for ``imutherm compare
    --thermal-only`` and its report; the paper's columns only where ``data`` has the paper's figures.

    ``data``: the ``compare.json`` content, ``{"paper": figures or absent, "schemes": {scheme: result_summary}}``.
    """
    paper, rows = data.get("paper"), []
    for s, r in data["schemes"].items():
        meas = (paper or {}).get("measured", {}).get(s, {})
        settle = meas.get("near_steady_s", meas.get("steady_s"))
        sites = r["sites"]
        t95 = sites.get("tp1", {}).get("t95_s")
        sim = (paper or {}).get("simulated_max_rise_K", {}).get(s, float("nan"))
        rows.append([s, f"{r.get('steady_max_rise_K', r['max_rise_K']):.1f}", f"{sim:.0f}", r["hottest_part"]]
                    + [f"{sites[t]['rise_K']:.1f}" if t in sites else "-" for t in ("tp1", "tp2", "tp3")]
                    + ["-" if r.get(k) is None else f"{r[k]:.2f}" for k in ("gyro_spread_K", "accel_spread_K")]
                    + ["-" if t95 is None else f"{t95:.0f}", "-" if settle is None else f"{settle:.0f}",
                       f"{r['energy_balance_rel_error']:.0e}"])
    keep = [i for i in range(len(TABLE_COLUMNS)) if paper is not None or i not in _PAPER_COLUMNS]
    return [TABLE_COLUMNS[i] for i in keep], [[row[i] for i in keep] for row in rows]


@dataclass(frozen=True)
class Comparison:
    """The three schemes' results: ``runs`` scheme -> SchemeResult, ``summaries`` scheme -> result dict."""

    runs: dict
    summaries: dict


def compare_schemes(layout=None, schemes=("air", "grease", "potted"), *, progress: bool = False,
                    jobs: int | None = None, use_cache: bool = True, **run_kwargs) -> Comparison:
    """Run every scheme (steady + transient by default) with the same mesh and model options.

    jobs : int, worker processes (default: min(2, CPUs), no more than the schemes); 1 solves the schemes one
        after another in this process. With more, they are solved side by side, the longest first, and the
        mesh-error estimates' refined solves (``estimate_mesh_error=True``, ~8x a scheme's memory) one at a
        time, as in the end-to-end study (:func:`imutherm.studies.end_to_end.run_study`).
    use_cache : read each scheme's result from the disk cache when one of the same content is there, and keep it
        there (:func:`imutherm.studies.end_to_end.thermal.cached_scheme_run`)
    **run_kwargs : passed to :func:`imutherm.studies.thermal.thermal_study.run_scheme`
    """
    import time
    from concurrent.futures import as_completed

    from imutherm.studies.thermal.thermal_study import longest_first
    from imutherm.unit.model import ModelOptions
    from imutherm.workers import check_jobs, process_pool, usable_workers

    layout = load_layout(layout) if not hasattr(layout, "schemes") else layout
    unknown = [s for s in schemes if s not in layout.schemes]
    if unknown:
        raise InputError(f"{layout.path}: unknown scheme(s) {unknown}; valid: {', '.join(layout.schemes)}")
    jobs = usable_workers(check_jobs(jobs), len(schemes))
    run_kwargs.setdefault("transient", True)
    runs = {}
    if jobs == 1:
        for s in schemes:
            if progress:
                print(f"scheme {s}: solving ...", flush=True)
            runs[s] = _scheme_task(layout, s, {**run_kwargs, "progress": progress}, use_cache)
        return Comparison(runs, {s: result_summary(r) for s, r in runs.items()})
    if progress:
        print(f"solving {', '.join(schemes)} in {jobs} processes ...", flush=True)
    start = time.perf_counter()
    pool = process_pool(jobs, shared_lock=True)
    try:
        order = longest_first(layout, schemes, run_kwargs.get("options") or ModelOptions())
        futs = {pool.submit(_scheme_task, layout, s, run_kwargs, use_cache): s for s in order}
        for f in as_completed(futs):
            runs[futs[f]] = f.result()
            if progress:
                print(f"scheme {futs[f]}: done ({runs[futs[f]].wall_s:.0f} s; {time.perf_counter() - start:.0f} s "
                      "since the start)", flush=True)
    finally:
        pool.shutdown(cancel_futures=True)
    runs = {s: runs[s] for s in schemes}
    return Comparison(runs, {s: result_summary(r) for s, r in runs.items()})


def _scheme_task(layout, scheme: str, run_kwargs: dict, use_cache: bool = True) -> SchemeResult:
    """One scheme of :func:`compare_schemes` (in a worker or in this process): :func:`run_scheme`, then its
    mesh-error estimate under the workers' lock, or the result from the disk cache
    (:func:`imutherm.studies.end_to_end.thermal.cached_scheme_run`)."""
    from imutherm.studies.end_to_end.thermal import cached_scheme_run

    return cached_scheme_run(layout, scheme, run_kwargs, use_cache)


def write_comparison(comp: Comparison, out: str | os.PathLike, model: dict | None = None) -> None:
    """``compare.json``, ``probes_<scheme>.csv`` and ``map_<scheme>.npz`` in ``out``; ``model``: the fitted
    model the comparison ran on (:meth:`imutherm.studies.thermal.fitted_model.FittedModel.summary`), if any."""
    from imutherm.studies.paper import bench_comparison

    out = Path(out)
    layout = next(iter(comp.runs.values())).geometry.layout
    paper, bench = paper_thermal(layout), bench_comparison(layout, model_curves(comp.runs))
    write_json(out / "compare.json", {**({"paper": paper} if paper is not None else {}), "schemes": comp.summaries,
                                      **({"reference": bench} if bench is not None else {}),
                                      **({"model": model} if model is not None else {})})
    for s, res in comp.runs.items():
        header, rows = probe_table(res)
        write_site_table(out / f"probes_{s}.csv", rows[:, 0], header[1:], rows[:, 1:])
        np.savez_compressed(out / f"map_{s}.npz", **board_plane_map(res))
