"""The influence of each input of a sweep on each output.

SALib's Morris measures (mu*, sigma) and Sobol' indices (S1, ST) where the design is complete, else the
standardised regression coefficients of a linear least-squares fit with its R^2 (:func:`sensitivity`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from imutherm.studies.sweep.plan import MORRIS_LEVELS

if TYPE_CHECKING:  # pragma: no cover
    from imutherm.studies.sweep.plan import SweepPlan

def sensitivity(plan: SweepPlan, rows: list) -> dict:
    """Influence of each input on each output.

    morris: SALib ``analyze.morris`` (mu*, sigma, mu* confidence) when every case is ok;
    sobol: SALib ``analyze.sobol`` first-order S1 and total ST indices with their 95 % confidence half-widths
    (bootstrap, seeded) when every case is ok; otherwise (and for grid / lhs): standardised regression coefficients (SRC) of a linear
    least-squares fit of the standardised output on the standardised inputs over the ok cases,
    with the fit's R^2 (SRC ranks inputs well only where R^2 is near 1).

    Returns {"measure", "note", "outputs": {output: {"by_key": {key: {...}}, "r2"?}},
    "ranking": [keys, most influential on max_rise_K first]}.
    """
    ok = [r for r in rows if r["status"] == "ok"]
    keys = plan.keys
    out = {"measure": None, "note": "", "outputs": {}, "ranking": []}
    method = plan.design["method"]
    complete = len(ok) == len(plan.cases)
    use_morris = method == "morris" and complete
    if method in ("morris", "sobol") and not complete:
        what = "Morris measures" if method == "morris" else "Sobol' indices"
        out["note"] = (f"{what} need every case of the design; {len(plan.cases) - len(ok)} of "
                       f"{len(plan.cases)} failed or missing, so SRC over the ok cases is given instead")
    if method == "sobol" and complete:
        from SALib.analyze import sobol

        out["measure"] = "sobol"
        problem = {"num_vars": len(keys), "names": list(keys), "bounds": [list(f.bounds) for f in plan.factors]}
        by_id = {r["case"]: r for r in ok}
        for name in plan.outputs:
            Y = np.array([np.nan if by_id[c.case_id][name] is None else by_id[c.case_id][name]
                          for c in plan.cases], float)
            if not np.all(np.isfinite(Y)) or Y.std() == 0:
                continue
            res = sobol.analyze(problem, Y, calc_second_order=False, conf_level=0.95,
                                seed=plan.design["seed"])
            out["outputs"][name] = {"by_key": {k: {m: float(res[m][i]) for m in ("S1", "S1_conf", "ST", "ST_conf")}
                                               for i, k in enumerate(keys)}}
        metric = "ST"
    elif use_morris:
        from SALib.analyze import morris

        out["measure"] = "morris_mu_star"
        problem = {"num_vars": len(keys), "names": list(keys), "bounds": [list(f.bounds) for f in plan.factors]}
        by_id = {r["case"]: r for r in ok}
        for name in plan.outputs:
            Y = np.array([by_id[c.case_id][name] if by_id[c.case_id][name] is not None else np.nan
                          for c in plan.cases], float)
            if not np.all(np.isfinite(Y)):
                continue
            res = morris.analyze(problem, plan.X, Y, num_levels=MORRIS_LEVELS,
                                 seed=np.random.default_rng(plan.design["seed"]))
            out["outputs"][name] = {"by_key": {k: {"mu_star": float(res["mu_star"][i]), "sigma": float(res["sigma"][i]),
                                                   "mu_star_conf": float(res["mu_star_conf"][i])}
                                               for i, k in enumerate(keys)}}
        metric = "mu_star"
    else:
        out["measure"] = "src"
        X = np.array([[r[k] for k in keys] for r in ok], float).reshape(len(ok), len(keys))
        sx = X.std(axis=0) if len(ok) else np.zeros(len(keys))
        live = [i for i in range(len(keys)) if sx[i] > 0]
        for name in plan.outputs:
            y = np.array([np.nan if r[name] is None else r[name] for r in ok], float)
            good = np.isfinite(y)
            if good.sum() < len(live) + 2 or not live:
                continue
            Xs = (X[good][:, live] - X[good][:, live].mean(0)) / X[good][:, live].std(0)
            if np.any(~np.isfinite(Xs)) or y[good].std() == 0:
                continue
            ys = (y[good] - y[good].mean()) / y[good].std()
            A = np.column_stack([Xs, np.ones(len(ys))])
            coef, *_ = np.linalg.lstsq(A, ys, rcond=None)
            r2 = float(1.0 - np.sum((ys - A @ coef) ** 2) / np.sum(ys ** 2))
            out["outputs"][name] = {"r2": r2, "by_key": {keys[i]: {"src": float(coef[j])} for j, i in enumerate(live)}}
        metric = "src"
    primary = out["outputs"].get("max_rise_K")
    if primary:
        out["ranking"] = sorted(primary["by_key"], key=lambda k: -abs(primary["by_key"][k][metric]))
    return out
