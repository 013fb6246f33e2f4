"""The next experiment: the bench design that best separates the candidates an ambiguous correlation leaves.

When several explanations fit the data equally (verdict ``ambiguous``), each candidate's fitted model (its effect
and the re-tune, as fitted) predicts what any further experiment would read. Over the designs a bench can run
(:func:`designs`: a cooling scheme and ambient the correlation has a reduced model for, a power scale, a
duration, the probes of the files so far plus at most one more at a named site), the one chosen maximises the
smallest pairwise separation of the leading candidates' predicted readings against what blurs them:

    z = RMS over the file's readings of (y_a - y_b) / RMS of s,   s² = noise² + (form fraction × rise)²

(the form fraction: the model's stated form error per scheme, :mod:`imutherm.studies.correlation.form_error`, applied to
the mean predicted rise: a smooth model error of that size could mimic the difference there). Both are taken over
the whole file, as the test that settles it does (:mod:`~imutherm.studies.correlation.file_test`: a candidate
must halve its rivals' RMS miss of the file): a pointwise maximum (until issue 58's seed 63) promised designs
whose difference sat at one probe for one minute (0.87 K at an added probe after 75 s, 10 sigmas pointwise) and
settled none. A design is expected to settle the question when z >= :data:`SETTLE_SIGMAS` for every pair.

What separates is what the second correlation will test (issue 58, seed 63: four designs promised at 10-17
sigmas settled none). With the discrepancy term a candidate is named where it explains the model's error
(:func:`~imutherm.studies.correlation.verdict.explains_term`) or predicts a file it was not fitted to better than
its rivals and the re-tuned model, the term carried over from the files of the same scheme
(:mod:`~imutherm.studies.correlation.file_test`). So each candidate's readings of a design are predicted as that
test predicts them: its model at its fitted values less the term it fitted, as fractions of each site's nominal
rise, carried over to the design's probes (where the files of the design's scheme and ambient measure that site;
elsewhere none), and with ``reference`` (the re-tuned model alone, the model's own error) each candidate the
term's standard refuses (``against``) must be separated from it too: for such a candidate only that test can
settle it, and a design that tells the candidates apart but not from the model's form settles nothing. (Asked of
every candidate, with the term carried over, the slow FEM closed loop's proposed design changed and left the 5 V
regulator ambiguous with the 3.3 V one.)
The form fraction in s is then what the carried term does not predict.
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


def _design_model(fwd, scheme: str, amb: float, ps: float, dur: float):
    """(times [s], a one-run forward model of the design at every site of the reduced model)."""
    from imutherm.studies.correlation.forward_model import ForwardModel
    rom = fwd.roms[(scheme, amb)]
    t = np.linspace(0.0, dur, DESIGN_SAMPLES + 1)[1:]
    sites = tuple(rom.site_names)
    probe = fwd.runs[0].probe if fwd.runs else "die"
    run = MeasuredRun("next.csv", scheme, amb, ps, 0.0, probe, sites, t, np.zeros((len(t), len(sites))),
                      tuple(range(len(t))))
    return t, ForwardModel((run,), fwd.roms, fwd.geometries, fwd.options, fwd.form)


def carried_term(fwd, coefs: dict, scheme: str, amb: float) -> dict:
    """site -> the term's coefficients (2,) [-] a fit carries to a new file of ``scheme`` at ``amb``: the mean over
    the runs of that scheme and ambient measuring the site (``coefs``: (run, site index) -> (2,), a Fit's
    ``disc``)."""
    acc = {}
    for (i, j), c in (coefs or {}).items():
        r = fwd.runs[i]
        if r.scheme == scheme and r.ambient_C == amb:
            acc.setdefault(r.sites[j], []).append(np.asarray(c, float))
    return {s: np.mean(cs, axis=0) for s, cs in acc.items()}


def predicted_readings(fwd, scheme: str, amb: float, ps: float, dur: float, values: dict,
                       coefs: dict | None = None) -> tuple:
    """(times [s], the rises [K] at every site (n, m) a file of the design would read by the model at ``values``
    with the term ``coefs`` carried over (:func:`carried_term`), site names) of one design."""
    t, f = _design_model(fwd, scheme, amb, ps, dur)
    y = f.rise(0, values)
    sites = f.runs[0].sites
    carried = carried_term(fwd, coefs, scheme, amb)
    if carried:
        y0, dT = f.rise(0, fwd.nominal), f.rise(0, fwd.nominal, [np.inf])[0]
        for j, site in enumerate(sites):
            if site in carried and dT[j] > 0:
                s = np.clip(y0[:, j] / dT[j], 0.0, 1.0)
                y[:, j] -= np.column_stack([dT[j] * s, dT[j] * 4 * s * (1 - s)]) @ carried[site]
    return t, y, sites


def next_experiment(fwd, leading, noise_K: float, form_fraction: dict, reference=None, against=()) -> dict | None:
    """The design that best separates ``leading`` (a list of (name, fitted values[, the fit's term coefficients,
    ``Fit.disc``]) of two or more candidates) from each other, and those named in ``against`` from ``reference``
    (the same form: the re-tuned model alone; None: not asked), see the module docstring; None with fewer than two
    candidates. Returns the
    design (scheme, ambient_C, power_scale,
    duration_s, probes, added_probe), ``separation_sigmas`` (z of the worst-separated pair), its
    ``separation_rms_K`` and largest difference ``separation_K``,
    ``pair``, ``site`` and ``time_s`` where that pair differs most, ``settles`` (>= :data:`SETTLE_SIGMAS`),
    ``candidates`` and ``in_words``: a sentence a test engineer can act on."""
    leading = list(leading)
    if len(leading) < 2:
        return None
    names = [x[0] for x in leading]
    against = [n for n in against if n in names] if reference is not None else []
    leading = leading + ([reference] if against else [])
    pairs = [(a, b) for a, b in itertools.combinations(range(len(leading)), 2)
             if b < len(names) or leading[a][0] in against]
    cache, scored = {}, []
    for d in designs(fwd):
        key = (d["scheme"], d["ambient_C"], d["power_scale"], d["duration_s"])
        if key not in cache:
            cache[key] = [predicted_readings(fwd, *key, *x[1:]) for x in leading]
        preds = cache[key]
        t, sites = preds[0][0], preds[0][2]
        cols = [sites.index(s) for s in d["probes"]]
        ys = [p[1][:, cols] for p in preds]
        frac = float(form_fraction.get(d["scheme"], max(form_fraction.values(), default=0.0)))
        s = np.sqrt(noise_K**2 + (frac * np.mean(ys, axis=0)) ** 2)
        worst = None
        for a, b in pairs:
            diff = np.abs(ys[a] - ys[b])
            z = float(np.sqrt(np.mean(diff**2) / np.mean(s**2)))
            k = np.unravel_index(int(np.argmax(diff)), diff.shape)  # where the pair differs most, for the words
            cand = (z, float(diff[k]), (leading[a][0], leading[b][0]), d["probes"][k[1]], float(t[k[0]]),
                    float(np.sqrt(np.mean(diff**2))))
            if worst is None or cand[0] < worst[0]:
                worst = cand
        scored.append((worst, d))
    # the best design; of those within 2 % of it, the shortest, nearest the nominal power, without an added probe
    top = max(w[0] for w, _ in scored)
    (z, sep, pair, site, t_at, sep_rms), d = min((x for x in scored if x[0][0] >= top / 1.02),
                                        key=lambda x: (x[1]["duration_s"], abs(x[1]["power_scale"] - 1.0),
                                                       x[1]["added_probe"] is not None))
    out = {**d, "probes": list(d["probes"]), "separation_K": sep, "separation_rms_K": sep_rms, "separation_sigmas": z,
           "pair": list(pair),
           "site": site, "time_s": t_at, "settles": z >= SETTLE_SIGMAS, "candidates": names,
           "reference": reference[0] if against else None, "against_reference": against,
           "sigma_includes": "noise and the stated form error of the rise (each model's term carried over)"}
    out["in_words"] = _words(out, noise_K)
    return out


def _words(x: dict, noise_K: float) -> str:
    kept = [p for p in x["probes"] if p != x["added_probe"]]
    logged = ", ".join(kept) + (f" and one more probe at {x['added_probe']}" if x["added_probe"] else "")
    verdict = ("expected to settle it" if x["settles"] else
               f"below {SETTLE_SIGMAS:g} sigmas: no design on the grid is expected to settle it")
    return (f"Next experiment: run the {x['scheme']} scheme at {x['ambient_C']:g} °C ambient and "
            f"{x['power_scale']:g}x "
            f"power for {x['duration_s']:.0f} s, logging {logged}. "
            f"{x['pair'][0]} and {x['pair'][1]} then differ by {x['separation_rms_K']:.2f} K RMS over the file "
            f"({x['separation_sigmas']:.1f} sigmas of noise {noise_K:.3f} K and form error), most at {x['site']}: "
            f"{x['separation_K']:.2f} K after {x['time_s']:.0f} s: "
            f"{verdict}. Add the file and run correlate again.")
