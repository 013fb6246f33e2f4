"""The residual sensor errors and the attitude error under what the thermal model does not know.

``imutherm compare --uncertainty`` (end-to-end) runs ``--uncertainty-imu-draws`` N of the uncertainty
design's draws (the first N points of its base Sobol' sequence, which fill the input space evenly)
through the **full IMU chain** of :func:`imutherm.studies.end_to_end.imu_case`: oven calibration with
the draw's self-heating, compensation, filters. Each draw's hand-off to the chain (:func:`draw_chain`)
is the nominal study's, moved by the scheme's reduced model from the nominal inputs to the draw's:

* power-on transient: the study's die-temperature curves plus the reduced model's change of the
  site curves, ``T(t) = T_study(t) + [rom(draw, t) - rom(nominal, t)]`` (on the study's time grid,
  extended to ``t_end`` past its end: the study's curve is held there, as the chain reads it);
* steady die temperatures: the same with the steady rises;
* the oven self-heating table: at the layout's ambient the draw's steady rise; at the other chamber
  temperatures the study's rise times the reduced model's ratio of the draw's steady site rise to the
  nominal one (the rise scales with the heat and the paths; checked against the full FEM at the
  uncertainty's check points, ``oven_error_K``), except the cavity law's blend, whose change is scaled to
  each oven temperature by the full FEM's rise at the blend's far end there (:func:`with_form_end`: radiation
  goes as T^3, so the laws differ less in a cold oven).

So a draw at the nominal inputs *is* the nominal study (bit for bit), and the reduced model's own
error against the full FEM cancels at the nominal point. The chain runs with the study's grade,
seeds and filter settings: the **same IMU seeds in every draw and scheme**, so the spread over the
draws is the thermal model's uncertainty, not the sensor noise draw; each draw's figure is the mean
over the seeds, as the study quotes it, and each difference between schemes is taken draw by draw.
Only the answer's configuration runs (its compensation, filter(s) and profile, calibrated in the unit).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from imutherm import InputError
from imutherm.unit.cavity_laws import LAW_BLEND
from imutherm.workers import process_pool

#: below this many draws the interval quoted is min .. max (5 / 95 % quantiles of a handful mean little)
MIN_DRAWS_FOR_QUANTILES = 20
DEFAULT_IMU_DRAWS = 16
RESIDUALS = ("gyro_rms_dps", "accel_rms_mg")


@dataclass(frozen=True)
class Chain:
    """One scheme's hand-off to the IMU chain (:func:`imutherm.studies.end_to_end.imu_case`).

    t_s (M,) [s], T_C (M, 6) [°C]: die temperatures over the power-on transient (``SITES`` order);
    steady_C (6,) [°C]; chamber_C (k,) [°C], rise_K (k, 6) [K]: self-heating in the oven; ambient_C [°C];
    form_end_rise_K (k, 6) [K] or None: the full FEM's oven self-heating with the cavity law's blend at its far
    end (:data:`FORM_KNOB` = 1, the other inputs nominal; the ambient's row unused), :func:`with_form_end`
    """

    t_s: np.ndarray
    T_C: np.ndarray
    steady_C: np.ndarray
    chamber_C: np.ndarray
    rise_K: np.ndarray
    ambient_C: float
    form_end_rise_K: np.ndarray | None = None


#: the input whose change of the rise depends on the oven's temperature far more than the others': the cavity
#: law's form (radiation goes as T^3, so at -40 °C the two laws differ less than at 70 °C). Mapped with the
#: 70 °C ratio like the others, the -40 °C self-heating was up to 3.7 K (26 %) under the full FEM (air, w 0.73,
#: 6 mm mesh); its change is scaled per oven temperature by the full FEM's at the blend's far end instead
FORM_KNOB = LAW_BLEND


def nominal_chain(scheme_study) -> Chain:
    """The nominal study's hand-off of one scheme (a :class:`~imutherm.studies.end_to_end.SchemeStudy`)."""
    from imutherm.imu.sensor_model import SITES
    from imutherm.studies.end_to_end import site_curves

    res = scheme_study.thermal
    t, T = site_curves(res)
    idx = [res.steady.probe_names.index(s) for s in SITES]
    return Chain(t, T, np.asarray(res.steady.probe_C, float)[idx], np.asarray(scheme_study.chamber_C, float),
                 np.asarray(scheme_study.rise_K, float), float(res.geometry.layout.ambient_C))


def _site_index(rom) -> list:
    from imutherm.imu.sensor_model import SITES

    missing = [s for s in SITES if s not in rom.site_names]
    if missing:
        raise InputError(f"the IMU chain needs a site per sensor die; the reduced model has no {', '.join(missing)}")
    return [list(rom.site_names).index(s) for s in SITES]


def draw_chain(nom: Chain, rom, values: dict, values0: dict, t_end: float) -> Chain:
    """The hand-off of one draw (module docstring): ``nom`` moved by ``rom`` from knob values ``values0`` (the
    nominal inputs) to ``values`` (the draw's); ``t_end`` [s] the transient's extent (beyond the study's end,
    the study's last reading is held and the reduced model's change goes on)."""
    idx = _site_index(rom)
    t = np.asarray(nom.t_s, float)
    if t_end > t[-1]:
        t = np.concatenate([t, np.linspace(t[-1], t_end, 41)[1:]])
    times = np.append(t, np.inf)
    d = rom.rise(values, times)[:, idx] - rom.rise(values0, times)[:, idx]
    base = np.column_stack([np.interp(t, nom.t_s, nom.T_C[:, j]) for j in range(nom.T_C.shape[1])])
    T = base + d[:-1]
    steady = nom.steady_C + d[-1]
    ss0 = rom.rise(values0, [np.inf])[0, idx]
    ratio = np.divide(ss0 + d[-1], ss0, out=np.ones_like(ss0), where=ss0 > 0)
    cold = [nom.rise_K[k] * ratio for k in range(len(nom.chamber_C))]
    if nom.form_end_rise_K is not None and FORM_KNOB in values and FORM_KNOB in values0:
        cold = _form_scaled(nom, rom, values, values0, idx, ss0)
    rise = np.array([nom.rise_K[k] + d[-1] if c == nom.ambient_C else cold[k] for k, c in enumerate(nom.chamber_C)])
    return Chain(t, T, steady, nom.chamber_C, rise, nom.ambient_C, nom.form_end_rise_K)


def _div(a, b):
    return np.divide(a, b, out=np.ones_like(a, dtype=float), where=b > 0)


def _form_scaled(nom: Chain, rom, values: dict, values0: dict, idx, ss0) -> list:
    """The oven self-heating at each chamber temperature with the cavity law's change scaled there: the study's
    rise times the other inputs' steady ratio (at the draw's blend w0, the reduced model) times the blend's
    factor f = rise(w) / rise(w0) at 70 °C moved to the chamber's by the full FEM's far-end factors,
    1 + (f - 1) (F_c - 1) / (F_a - 1), F = rise(w 1) / rise(w0) at the chamber (full FEM) and the ambient
    (reduced model). At the far end with the other inputs nominal it is the full FEM's rise exactly; at the
    nominal inputs the study's."""
    w0 = values0[FORM_KNOB]
    r_w0 = rom.rise(dict(values, **{FORM_KNOB: w0}), [np.inf])[0, idx]
    r = rom.rise(values, [np.inf])[0, idx]
    others, f = _div(r_w0, ss0), _div(r, r_w0)
    Fa = _div(rom.rise(dict(values0, **{FORM_KNOB: 1.0}), [np.inf])[0, idx], ss0)
    out = []
    for k in range(len(nom.chamber_C)):
        Fc = _div(nom.form_end_rise_K[k], nom.rise_K[k])
        g = np.divide(Fc - 1.0, Fa - 1.0, out=np.ones_like(Fc), where=np.abs(Fa - 1.0) > 1e-9)
        out.append(nom.rise_K[k] * others * (1.0 + (f - 1.0) * g))
    return out


def with_form_end(nom: Chain, sm, values0: dict, say=None) -> Chain:
    """``nom`` with :attr:`Chain.form_end_rise_K`: the full FEM's steady self-heating at each oven temperature
    other than the ambient with the cavity law's blend at 1 and the other inputs at ``values0`` (one full solve
    per oven temperature); ``nom`` unchanged if the scheme's reduced model does not carry the blend."""
    if FORM_KNOB not in values0:
        return nom
    if say:
        say(f"uncertainty: {sm.scheme}'s oven self-heating at the cavity law's far end on the full FEM")
    full = _oven_full(sm, dict(values0, **{FORM_KNOB: 1.0}), nom)
    end = np.array([full.get(k, nom.rise_K[k]) for k in range(len(nom.chamber_C))])
    return replace(nom, form_end_rise_K=end)


def _oven_full(sm, values: dict, nom: Chain) -> dict:
    """{chamber index: (6,) full-FEM steady site rise [K]} at each oven temperature other than the ambient."""
    from imutherm.imu.sensor_model import SITES
    from imutherm.studies.thermal.forward import full_rise
    from imutherm.studies.thermal.thermal_study import STUDY_CG_RTOL
    from imutherm.unit import knobs

    geo = sm.geometry
    probes = {s: geo.sites[s] for s in SITES}
    out = {}
    for k, Tc in enumerate(nom.chamber_C):
        if Tc == nom.ambient_C:
            continue
        lay = replace(geo.layout, ambient_C=float(Tc), mounting=replace(geo.layout.mounting, temperature_C=float(Tc)))
        out[k] = full_rise(knobs.variant(replace(geo, layout=lay), sm.options, values), sm.grid, probes,
                           np.array([np.inf]), rtol=STUDY_CG_RTOL)[0]
    return out


def answer_setting(config) -> tuple:
    """(compensation, filters, profile) of the study's answer: what the draws run (the answer's filter first,
    then ``kf`` if the study has it)."""
    from imutherm.studies.end_to_end import ANSWER_COMPENSATION, ANSWER_FILTER, ANSWER_PROFILE, ANSWER_SECOND_FILTER

    comp = ANSWER_COMPENSATION if ANSWER_COMPENSATION in config.compensations else config.compensations[-1]
    filt = ANSWER_FILTER if ANSWER_FILTER in config.filters else config.filters[0]
    prof = ANSWER_PROFILE if ANSWER_PROFILE in config.profiles else config.profiles[0]
    second = ANSWER_SECOND_FILTER
    filters = (filt,) + ((second,) if second in config.filters and filt != second else ())
    return comp, filters, prof


def draw_config(config):
    """The study's :class:`~imutherm.studies.end_to_end.StudyConfig` cut to the answer's configuration, with
    the same random streams: the profiles up to the answer's (each profile's noise stream is its position's),
    calibrated in the unit."""
    comp, filters, prof = answer_setting(config)
    profiles = config.profiles[:config.profiles.index(prof) + 1]
    return replace(config, profiles=profiles, compensations=(comp,), filters=filters, calibrations=("unit",))


def _attitude_outputs(config) -> list:
    """(name, phase, filter, axis) of the attitude outputs."""
    from imutherm.studies.end_to_end import PHASES

    _, filters, _ = answer_setting(config)
    return [(f"{ph}_{f}_{ax}_rms_deg", ph, f, ax) for f in filters for ph in PHASES for ax in ("roll", "pitch")]


def output_names(config) -> tuple:
    """The propagated outputs: ``<phase>_<filter>_<roll|pitch>_rms_deg`` [deg] (the answer's profile and
    compensation, calibrated in the unit) and the warm-up residuals ``gyro_rms_dps`` [°/s], ``accel_rms_mg`` [mg]."""
    return tuple(n for n, *_ in _attitude_outputs(config)) + RESIDUALS


def case_outputs(case: dict, config, key: str | None = None) -> dict:
    """The outputs (:func:`output_names`) of one :func:`~imutherm.studies.end_to_end.imu_case` result, or with
    ``key`` ("mean", "std") of :func:`~imutherm.studies.end_to_end.reduce_cases`' statistics over the seeds."""
    comp, _, prof = answer_setting(config)

    def leaf(v):
        return v[key] if key else v

    att = case["attitude"]["unit"]
    out = {n: leaf(att[ph][comp][f][prof][f"{ax}_rms_deg"]) for n, ph, f, ax in _attitude_outputs(config)}
    out.update({k: leaf(case["residuals"]["unit"][comp][k]) for k in RESIDUALS})
    return out


def study_figures(scheme_study, config) -> dict:
    """The nominal study's figure of each output: {name: {mean, std}} over its seeds."""
    m, s = case_outputs(scheme_study.imu, config, "mean"), case_outputs(scheme_study.imu, config, "std")
    return {k: {"mean": float(m[k]), "std": float(s[k])} for k in m}


def _case(grade, seed, chain: Chain, config):
    """One (draw, scheme, seed) through the chain: (outputs or None, error or None, CPU seconds)."""
    from imutherm.studies.end_to_end import imu_case

    c0 = time.process_time()
    try:
        case = imu_case(grade, seed, chain.t_s, chain.T_C, chain.steady_C, chain.chamber_C, chain.rise_K, config)
    except InputError as e:
        return None, str(e), time.process_time() - c0
    return case_outputs(case, config), None, time.process_time() - c0


def draw_stats(y) -> dict:
    """n, min, median, max (and q05 / q95 from :data:`MIN_DRAWS_FOR_QUANTILES` draws) of one output over the
    draws, and the interval quoted (``lo``, ``hi``, ``interval``: "5-95 %" or "min-max")."""
    y = np.asarray(y, float)
    y = y[np.isfinite(y)]
    if not y.size:
        return {"n": 0, "min": None, "q50": None, "max": None, "lo": None, "hi": None, "interval": None}
    out = {"n": int(y.size), "min": float(y.min()), "q50": float(np.median(y)), "max": float(y.max()),
           "mean": float(y.mean())}
    if y.size >= MIN_DRAWS_FOR_QUANTILES:
        out.update(q05=float(np.quantile(y, 0.05)), q95=float(np.quantile(y, 0.95)))
        out.update(lo=out["q05"], hi=out["q95"], interval="5-95 %")
    else:
        out.update(lo=out["min"], hi=out["max"], interval="min-max")
    return out


def run_imu_draws(chains: dict, config, *, jobs: int = 1, progress=None) -> dict:
    """Every draw of every scheme through the IMU chain, the study's seeds in each.

    chains : {scheme: [Chain, ...]} (the same draws, in the same order, in every scheme); config : the study's
    StudyConfig (cut by :func:`draw_config`); jobs : processes. Returns {"values": {"<output>:<scheme>": [per draw,
    mean over the seeds]}, "failed": [{draw, scheme, seed, error}], "cpu_s", "wall_s"}; a draw that fails in any
    scheme or seed (e.g. a die beyond the sensor model's range) is NaN in every scheme.
    """
    cfg = draw_config(config)
    seeds = tuple(range(config.seed0, config.seed0 + config.seeds))
    names = output_names(config)
    tasks = [(s, k, seed) for s, cs in chains.items() for k in range(len(cs)) for seed in seeds]
    t0 = time.perf_counter()
    if progress:
        progress(f"uncertainty: {len(next(iter(chains.values())))} draws x {len(chains)} schemes x {len(seeds)} seeds "
                 f"through the IMU chain ({', '.join(cfg.filters)}, {cfg.compensations[0]}, {cfg.profiles[-1]}) ...")
    if jobs > 1 and len(tasks) > 1:
        with process_pool(jobs) as pool:   # one BLAS thread each
            futs = [pool.submit(_case, config.grade, seed, chains[s][k], cfg) for s, k, seed in tasks]
            results = [f.result() for f in futs]
    else:
        results = [_case(config.grade, seed, chains[s][k], cfg) for s, k, seed in tasks]
    n = len(next(iter(chains.values())))
    acc = {(name, s): np.zeros((n, len(seeds))) for name in names for s in chains}
    failed, bad = [], set()
    for (s, k, seed), (out, err, _) in zip(tasks, results):
        if err is not None:
            failed.append({"draw": k, "scheme": s, "seed": seed, "error": err})
            bad.add(k)
            continue
        for name in names:
            acc[(name, s)][k, seeds.index(seed)] = out[name]
    values = {}
    for (name, s), a in acc.items():
        v = a.mean(axis=1)
        v[sorted(bad)] = np.nan
        values[f"{name}:{s}"] = v
    return {"values": values, "failed": failed, "cpu_s": float(sum(r[2] for r in results)),
            "wall_s": time.perf_counter() - t0}


def pair_stats(values: dict, schemes, names) -> dict:
    """{"<output>:<scheme>": draw_stats, "diff_<output>:<a>-<b>": draw_stats of the draw-by-draw difference}."""
    out = {k: draw_stats(v) for k, v in values.items()}
    for i, a in enumerate(schemes):
        for b in schemes[i + 1:]:
            for name in names:
                out[f"diff_{name}:{a}-{b}"] = draw_stats(values[f"{name}:{a}"] - values[f"{name}:{b}"])
    return out


def answer_words(stats: dict, nominal: dict, schemes, config) -> list:
    """One sentence per pair of schemes and axis on the answer's attitude error (warm-up roll / pitch RMS of the
    answer's filter): is one scheme's advantage larger than what the model does not know (the interval of the
    draw-by-draw difference excludes zero)? And is it larger than the nominal study's seed-to-seed spread of the
    difference (the unit-to-unit and noise draw, which the draws hold fixed)?"""
    comp, filters, prof = answer_setting(config)
    lines = []
    for i, a in enumerate(schemes):
        for b in schemes[i + 1:]:
            for ax in ("roll", "pitch"):
                name = f"warmup_{filters[0]}_{ax}_rms_deg"
                s = stats.get(f"diff_{name}:{a}-{b}")
                if not s or s["n"] == 0:
                    continue
                lo, mid, hi = (f"{s[q]:+.3f}" for q in ("lo", "q50", "hi"))
                na, nb = nominal.get(f"{name}:{a}"), nominal.get(f"{name}:{b}")
                spread = math.hypot(na["std"], nb["std"]) if na and nb else None
                if s["lo"] > 0 or s["hi"] < 0:
                    better, worse = (b, a) if s["lo"] > 0 else (a, b)
                    verdict = (f"{better}'s attitude error is lower than {worse}'s over the whole interval: the "
                               f"advantage is larger than the model's uncertainty")
                    if spread is not None and min(abs(s["lo"]), abs(s["hi"])) < spread:
                        verdict += (f", but not larger than the sensors' seed-to-seed spread of the difference in the "
                                    f"nominal study (+/-{spread:.3f} deg): not an advantage beyond the unit-to-unit "
                                    f"and noise draw")
                else:
                    verdict = "the interval includes zero: the difference is within the model's uncertainty"
                seed = (f" (the nominal study's difference {na['mean'] - nb['mean']:+.3f} deg, its seed spread "
                        f"+/-{spread:.3f} deg)" if spread is not None else "")
                lines.append(f"attitude error ({filters[0]}, {prof} warm-up, {ax} RMS, {comp} compensation calibrated "
                             f"in the unit), {a} - {b}: median {mid} deg ({s['interval']} over {s['n']} draws through "
                             f"the IMU chain: {lo} .. {hi} deg){seed}; {verdict}.")
    return lines


def oven_check(sm, values0: dict, nom: Chain, values: dict) -> dict:
    """The draw's oven self-heating table (:func:`draw_chain`) against the full FEM solved at each chamber
    temperature other than the ambient with the draw's knobs: largest error [K] and the full FEM's rises."""
    ch = draw_chain(nom, sm.rom, values, values0, float(nom.t_s[-1]))
    err, full = 0.0, {}
    for k, f in _oven_full(sm, values, nom).items():
        full[f"{nom.chamber_C[k]:g}"] = f.tolist()
        err = max(err, float(np.max(np.abs(f - ch.rise_K[k]))))
    return {"oven_error_K": err, "oven_full_rise_K": full,
            "oven_mapped_rise_K": {f"{c:g}": ch.rise_K[k].tolist() for k, c in enumerate(nom.chamber_C)}}


