"""The next experiment: the bench design that best separates the candidates an ambiguous correlation leaves.

When several explanations fit the data equally (verdict ``ambiguous``), each candidate's fitted model (its effect
and the re-tune, as fitted) predicts what any further experiment would read. Over the designs a bench can run
(:func:`designs`: a cooling scheme and ambient the correlation has a reduced model for, a power scale, a
duration, the probes of the files so far plus at most one more at a named site), the one chosen maximises the
smallest pairwise separation of the leading candidates' predicted readings against what blurs them:

    z = max over readings |y_a - y_b| / s,   s² = noise² + (form fraction × rise)²

(the form fraction: the model's stated form error per scheme, :mod:`imutherm.studies.correlation.form_error`, applied to
the mean predicted rise: a smooth model error of that size could mimic the difference there). The pointwise
maximum is the conservative reading of a separation: a smooth form error does not average away over readings.
A design is expected to settle the question when z >= :data:`SETTLE_SIGMAS` for every pair.

Ambients other than those of the reduced models built are not offered: each costs a reduced-model build (about a
minute at the default mesh), which a correlation does not do for a proposal; say so in the words.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from imutherm.measured import MeasuredRun

#: power scales a bench supply can set (the unit's nominal power times this) [-]: half to one and a half, the
#: range the unit's regulators are specified over is wider; recalled, not checked against a datasheet
DESIGN_POWER_SCALES = (0.5, 1.0, 1.5)
#: durations [s]: a quarter hour to two hours (the reference unit's slowest t63 is ~100-200 s; two hours reaches
#: the plateau of every site, docs/correlation.md)
DESIGN_DURATIONS_S = (900.0, 1800.0, 3600.0, 7200.0)
#: readings per site of a proposed file (a 15 s to 2 min logging interval over the durations above)
DESIGN_SAMPLES = 60
#: the separation [noise-and-form sigmas] at which the proposed experiment is expected to settle the question
SETTLE_SIGMAS = 3.0


def designs(fwd) -> list:
    """Every design of the grid: dicts (scheme, ambient_C, power_scale, duration_s, probes, added_probe)."""
    out = []
    for (scheme, amb), rom in sorted(fwd.roms.items()):
        measured = sorted({s for r in fwd.runs if r.scheme == scheme for s in r.sites}
                          or {s for r in fwd.runs for s in r.sites})
        measured = [s for s in measured if s in rom.site_names]
        extras = [None] + [s for s in rom.site_names if s not in measured]
        for ps, dur, extra in itertools.product(DESIGN_POWER_SCALES, DESIGN_DURATIONS_S, extras):
            probes = tuple(measured + ([extra] if extra else []))
            if probes:
                out.append({"scheme": scheme, "ambient_C": float(amb), "power_scale": ps, "duration_s": dur,
                            "probes": probes, "added_probe": extra})
    return out


def _predict(fwd, scheme: str, amb: float, ps: float, dur: float, values: dict) -> tuple:
    """(times [s], the model's rises [K] at every site of the reduced model (n, m), site names) of one design."""
    from imutherm.studies.correlation.forward_model import ForwardModel
    rom = fwd.roms[(scheme, amb)]
    t = np.linspace(0.0, dur, DESIGN_SAMPLES + 1)[1:]
    sites = tuple(rom.site_names)
    probe = fwd.runs[0].probe if fwd.runs else "die"
    run = MeasuredRun("next.csv", scheme, amb, ps, 0.0, probe, sites, t, np.zeros((len(t), len(sites))),
                      tuple(range(len(t))))
    f = ForwardModel((run,), fwd.roms, fwd.geometries, fwd.options, fwd.form)
    return t, f.rise(0, values), sites


def next_experiment(fwd, leading, noise_K: float, form_fraction: dict) -> dict | None:
    """The design that best separates ``leading`` (a list of (name, fitted values) of two or more candidates), see
    the module docstring; None with fewer than two. Returns the design (scheme, ambient_C, power_scale,
    duration_s, probes, added_probe), ``separation_K`` and ``separation_sigmas`` (of the worst-separated pair),
    ``pair``, ``site`` and ``time_s`` where that pair differs most, ``settles`` (>= :data:`SETTLE_SIGMAS`),
    ``candidates`` and ``in_words``: a sentence a test engineer can act on."""
    leading = list(leading)
    if len(leading) < 2:
        return None
    cache, scored = {}, []
    for d in designs(fwd):
        key = (d["scheme"], d["ambient_C"], d["power_scale"], d["duration_s"])
        if key not in cache:
            cache[key] = [_predict(fwd, *key, v) for _, v in leading]
        preds = cache[key]
        t, sites = preds[0][0], preds[0][2]
        cols = [sites.index(s) for s in d["probes"]]
        ys = [p[1][:, cols] for p in preds]
        frac = float(form_fraction.get(d["scheme"], max(form_fraction.values(), default=0.0)))
        s = np.sqrt(noise_K**2 + (frac * np.mean(ys, axis=0)) ** 2)
        worst = None
        for a, b in itertools.combinations(range(len(ys)), 2):
            z = np.abs(ys[a] - ys[b]) / s
            k = np.unravel_index(int(np.argmax(z)), z.shape)
            cand = (float(z[k]), float(abs(ys[a] - ys[b])[k]), (leading[a][0], leading[b][0]), d["probes"][k[1]],
                    float(t[k[0]]))
            if worst is None or cand[0] < worst[0]:
                worst = cand
        scored.append((worst, d))
    # the best design; of those within 2 % of it, the shortest, nearest the nominal power, without an added probe
    top = max(w[0] for w, _ in scored)
    (z, sep, pair, site, t_at), d = min((x for x in scored if x[0][0] >= top / 1.02),
                                        key=lambda x: (x[1]["duration_s"], abs(x[1]["power_scale"] - 1.0),
                                                       x[1]["added_probe"] is not None))
    out = {**d, "probes": list(d["probes"]), "separation_K": sep, "separation_sigmas": z, "pair": list(pair),
           "site": site, "time_s": t_at, "settles": z >= SETTLE_SIGMAS, "candidates": [n for n, _ in leading],
           "sigma_includes": "noise and the stated form error of the rise"}
    out["in_words"] = _words(out, noise_K)
    return out


def _words(x: dict, noise_K: float) -> str:
    kept = [p for p in x["probes"] if p != x["added_probe"]]
    logged = ", ".join(kept) + (f" and one more probe at {x['added_probe']}" if x["added_probe"] else "")
    verdict = ("expected to settle it" if x["settles"] else
               f"below {SETTLE_SIGMAS:g} sigmas: no design on the grid is expected to settle it")
    return (f"Next experiment: run the {x['scheme']} scheme at {x['ambient_C']:g} °C ambient and {x['power_scale']:g}x "
            f"power for {x['duration_s']:.0f} s, logging {logged}. "
            f"{x['pair'][0]} and {x['pair'][1]} then differ by {x['separation_K']:.2f} K at {x['site']} after "
            f"{x['time_s']:.0f} s ({x['separation_sigmas']:.1f} sigmas of noise {noise_K:.3f} K and form error): "
            f"{verdict}. Add the file and run correlate again.")
