"""Campaign at model-form errors of 2, 5 and 10 % of the rise (issue 58 item 3), with the rules set first.

RULES, set on 2026-12-07 before any case of this campaign was run, not changed after:

- **strong case**: a hidden library effect or a re-tune knob moved far whose signature (RMS change it makes at
  the readings, truth model with and without it) is >= :data:`STRONG_SIGMAS` noise sigmas;
- **named right**: the first thing named (``named_first`` of correlation.json: a finding or a library effect) is
  the hidden one; for an ambiguous verdict the proposed next experiment is made by the same generator (same
  truth, same form error), the file added and correlate run again: **settled right** when the hidden one is then
  named first; a strong case counts as named right if named right directly or settled right;
- **null**: any library name or finding where nothing was hidden is a false name;
- **written model**: its held-out RMS must not exceed the nominal model's;
- the **form error level**: a smooth error of the model's form, its RMS over a file's readings set to the level
  times the file's RMS rise; probe noise 0.05 K added after.

Targets (issue 58): strong named right >= 80 %; false names on nulls <= 5 %; ambiguous settled right >= 70 %;
written model never worse than nominal.

Generator: ``toy`` only (tests/_toy_reduced.py's closed-form rises as the truth, the correlation on the same toy
as its reduced models): the form error of each scheme is a per-site gain error of random sign and size with a
random first-order response (50-400 s), not any knob's or effect's pattern; seconds a case. These are
**development figures** (the toy is the rules' own test bed), not a blind set: a campaign on the finite-element
generator's other forms (layered contacts, the other cavity law, a grid 2-4x coarser or finer, nuisance on every
conductivity; ``benchmarks/bench_correlation.py --model-form``) takes 15-30 min a case on this machine and was
not run for this script.

    python benchmarks/bench_correlation_forms.py --cases 4 --out /tmp/forms

**FEM generator** (``--generator fem --form layered|cavity_law|grid|nuisance``; issue 58 item 3; rules below set on
2026-12-07 before any FEM case ran, and not changed after). The same rules as above (strong at >= 5 noise sigmas,
named right, settled right, null false names, written model), with:

- the truth: the full FEM (:func:`imutherm.studies.correlation.form_generator.form_pair`) of the unit (default layout, air and
  grease at 70 C, 1500 s, 40 readings at tp1-3 and the three gyros), the mount, the board's conductivity and the
  convection off by ±10 % (as ``make_case``), one hidden kind of :data:`FEM_KINDS`: none; a library power error at
  the 5 V regulator or the processor (the library's own draw, ±0.1-0.5 W); a poor board joint (its draw); the cavity's
  emissivity (its draw, 0.02-0.3 against 0.77: a re-tune knob moved far, a finding); the mount at 0.3-0.5x (a
  finding); a radiant lid load 150-400 W/m^2 (outside the library: scored apart, any library name or finding a
  false name);
- the form: the same truth run twice on the full FEM, on the inversion's own form (its laws, its 4 mm mesh and 1
  cell across thin parts) and on the one other form asked (``layered``: every contact a resolved 0.1 mm layer;
  ``cavity_law``: the other cavity-radiation law; ``grid``: a mesh 2x finer, 2 cells across thin parts;
  ``nuisance``: ±10 % on every conductivity, contact and emissivity, drawn per case). The measured file is the
  inversion-form rise plus ``k`` times the difference, one ``k`` per case set on its two standard files (air and
  grease together) so the difference's RMS is the level times the RMS rise: one form, one amplification, the
  schemes' shares of it the form's own (the form's natural level, ``k`` = 1, is recorded per case; where it is far
  below the level, the form's shape is judged, not its size); the proposed next experiment keeps the case's
  ``k``. Noise 0.05 K, no probe offsets (as the toy's rules). The achieved form error on a null case is reported
  as what the re-tuned model leaves (its RMS residual, the noise removed in quadrature, % of the RMS rise);
- the inversion: reduced models of the 4 mm mesh (``build_models``, air and grease at 70 C), candidates
  :data:`FEM_CANDIDATES` (the hidden library kinds and their nearest confusions), ``max_effects`` 3, no re-run;
- out-of-library cases: a library name or a finding is a false name (as a null); the verdict is reported.

One seed per campaign, one case per kind (the same truth under every form and level); development figures for
issue 58 item 3 on seed 61, the held-out figure on one fresh seed run once.

    python benchmarks/bench_correlation_forms.py --generator fem --form layered --seed 61 --out /tmp/forms_fem
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the toy reduced models

from imutherm.io import write_json  # noqa: E402
from imutherm.measured import MeasuredRun  # noqa: E402
from imutherm.studies.correlation import correlate, result_json  # noqa: E402

STRONG_SIGMAS = 5.0
LEVELS = (0.02, 0.05, 0.10)
NOISE_K = 0.05
CANDIDATES = ("power@reg_5v", "power@processor", "contact@bond")
#: hidden kinds and the range each value is drawn from [unit]: two regulator powers, a bond line, and two knobs
#: moved far (a finding each): the cavity's emissivity and the mount's conductance (0.35-0.5 of its nominal 500)
KINDS = {"none": None, "power@reg_5v": (0.3, 0.8), "power@processor": (0.3, 0.8), "contact@bond": (80.0, 250.0),
         "cavity_emissivity": (0.2, 0.45), "mount_h_W_m2K": (175.0, 250.0)}
SCHEMES = ("air", "grease")


def _verdict_fields(res, j: dict) -> dict:
    """A campaign row's fields from one correlation (``res``) and its JSON (``j``): verdict, names, findings,
    symptoms, the written model's held-out RMS [K] against nominal's, the proposed next experiment."""
    w = j["written_model"] or {}
    nx = res.next_experiment
    return {"verdict": res.verdict, "named_first": j["named_first"], "named_effects": list(res.named_effects),
            "findings": [f.parameter for f in res.findings], "symptoms": [x.parameter for x in res.symptoms],
            "ambiguous_set": list(res.ambiguous_set),
            "written_heldout_K": w.get("heldout_rms_K"), "nominal_heldout_K": w.get("nominal_heldout_rms_K"),
            "next_experiment": nx and {k: nx[k] for k in ("scheme", "power_scale", "duration_s", "probes",
                                                          "separation_K", "separation_sigmas")},
            "settled_first": None}


def _truth(kind: str, rng) -> tuple:
    """(truth values, hidden value): ±5 % nuisance on the board, mount and convection, and the hidden value."""
    nz = {"k_board_W_mK": 17.7 * rng.uniform(0.95, 1.05), "mount_h_W_m2K": 500.0 * rng.uniform(0.95, 1.05),
          "convection_scale": rng.uniform(0.95, 1.05)}
    if KINDS[kind] is None:
        return nz, None
    v = float(rng.uniform(*KINDS[kind]))
    if kind == "power@processor":  # a missing power leaves the part at least 20 % of its own 0.35 W (the layout's)
        v = max(v * rng.choice([-1.0, 1.0]), -0.8 * 0.35)
    return {**nz, kind: v}, v


def _form(rng) -> dict:
    """scheme -> (per-site relative gain error (6,) [-], response time [s]): the form error's shape."""
    return {s: (rng.uniform(-1.0, 1.0, 6), float(rng.uniform(50.0, 400.0))) for s in SCHEMES}


def _run(truth: dict, form: dict, level: float, rng, scheme: str, sites, times, power_scale=1.0,
         name=None) -> MeasuredRun:
    """A measured file of the toy: the truth's rise, the form error at ``level`` of its RMS rise, the noise."""
    from _toy_reduced import SITES, ToyReduced
    idx = [SITES.index(s) for s in sites]
    y = ToyReduced(scheme).rise({**truth, "power_scale": truth.get("power_scale", 1.0) * power_scale}, times)
    a, tau = form[scheme]
    shape = a[None, :] * y * (1.0 - np.exp(-np.asarray(times)[:, None] / tau))
    # the level is set on the campaign's standard file (all sites, 1500 s, nominal power) and kept for any other
    t0 = np.linspace(0.0, 1500.0, 40)
    y0 = ToyReduced(scheme).rise(truth, t0)
    s0 = a[None, :] * y0 * (1.0 - np.exp(-t0[:, None] / tau))
    k = level * np.sqrt(np.mean(y0**2)) / max(np.sqrt(np.mean(s0**2)), 1e-12)
    y = (y + k * shape)[:, idx] + rng.normal(0.0, NOISE_K, (len(times), len(idx)))
    return MeasuredRun(name or f"{scheme}.csv", scheme, 70.0, power_scale, 0.0, "die", tuple(sites),
                       np.asarray(times, float), 70.0 + y, tuple(range(len(times))))


def _signature(truth: dict, kind: str) -> float:
    """RMS [K] / noise of what the hidden one changes at the standard files' readings."""
    from _toy_reduced import ToyReduced
    base = dict(truth)
    base.pop(kind, None)
    t = np.linspace(0.0, 1500.0, 40)
    d = np.concatenate([(ToyReduced(s).rise(truth, t) - ToyReduced(s).rise(base, t)).ravel() for s in SCHEMES])
    return float(np.sqrt(np.mean(d**2)) / NOISE_K)


def one_case(kind: str, level: float, seed: int, models) -> dict:
    """Generate, correlate, and for an ambiguous verdict run the proposed experiment: one row."""
    from _toy_reduced import SITES
    rng = np.random.default_rng(seed)
    truth, value = _truth(kind, rng)
    form = _form(rng)
    t = np.linspace(0.0, 1500.0, 40)
    runs = [_run(truth, form, level, rng, s, SITES, t) for s in SCHEMES]
    t0 = time.perf_counter()
    res = correlate(runs, models=models, candidates=CANDIDATES, rerun=False)
    j = result_json(res)
    row = {"kind": kind, "value": value, "level": level, "seed": seed, **_verdict_fields(res, j),
           "signature_sigmas": None if value is None else _signature(truth, kind)}
    if res.verdict == "ambiguous" and res.next_experiment:
        nx = res.next_experiment
        tn = np.linspace(0.0, nx["duration_s"], 40)
        extra = _run(truth, form, level, rng, nx["scheme"], nx["probes"], tn, nx["power_scale"], "next.csv")
        again = correlate(runs + [extra], models=models, candidates=CANDIDATES, rerun=False)
        row["settled_first"] = result_json(again)["named_first"]
        row["settled_verdict"] = again.verdict
    row["seconds"] = time.perf_counter() - t0
    return row


#: the FEM campaign's hidden kinds: None (a null), 'draw' (the library's own draw), 'finding' (0.3-0.5x the
#: nominal), a range (outside the library)
FEM_KINDS = {"none": None, "power@reg_5v": "draw", "power@processor": "draw", "contact@board": "draw",
             "cavity_emissivity": "draw", "mount_h_W_m2K": "finding", "lid_heat_load": (150.0, 400.0)}
#: the FEM campaign's candidate effects: the hidden library kinds, the other regulators and contacts, a leak
FEM_CANDIDATES = ("power@reg_5v", "power@processor", "power@reg_3v3", "contact@board", "contact@standoff",
                  "fixture_leak")
FEM_SITES = ("tp1", "tp2", "tp3", "gyro_x", "gyro_y", "gyro_z")
FEM_MESH_MM, FEM_MIN_CELLS = 4.0, 1
#: directory of cached FEM pairs (``--pair-cache``; None: no cache): a pair depends on the truth and the design
#: only, not on the correlation's rules, so a campaign re-run after a rule change costs only the correlations
PAIR_CACHE = None


class FemCase:
    """One FEM case's truth and form: the measured files at any level, and a proposed design's file."""

    def __init__(self, kind: str, form: str, seed: int, models):
        from imutherm.geometry.build import build_geometry
        from imutherm.geometry.layout import load_layout
        from imutherm.studies.correlation.form_generator import form_options
        from imutherm.studies.correlation.hidden_effect import FINDING_FACTOR, draw_value
        from imutherm.unit import knobs
        rng = np.random.default_rng(seed)
        self.layout = load_layout(None)
        self.models, self.kind, self.seed, self.form = models, kind, seed, form
        self.geo = {s: build_geometry(self.layout, s) for s in SCHEMES}
        nom = knobs.nominal_values(self.geo["air"], models.options)
        self.truth = {k: nom[k] * (1 + rng.uniform(-0.10, 0.10))
                      for k in ("k_board_W_mK", "convection_scale", "mount_h_W_m2K")}
        how, self.value, self.lid = FEM_KINDS[kind], None, None
        if how == "draw":
            self.value = draw_value(kind, rng)
            if kind.startswith("power@"):  # a missing power leaves the part at least 10 % of its own
                from imutherm.unit.effects import power_part
                self.value = max(self.value, -0.9 * power_part(self.geo["air"], kind.split("@")[1]).power_W)
        elif how == "finding":
            self.value = float(nom[kind] * rng.uniform(*FINDING_FACTOR))
        elif how is not None:
            self.value = self.lid = float(rng.uniform(*how))
        if self.value is not None and self.lid is None:
            self.truth[kind] = self.value
        self.gen, self.gen_mesh, self.form_record = form_options(form, models.options, self.geo["air"], rng)
        self.rng = rng
        t = np.linspace(0.0, 1500.0, 40)
        self.std = {s: self._pair(s, 1.0, FEM_SITES, t) for s in SCHEMES}
        #: the form's natural level (k = 1) per scheme and over both: RMS difference / RMS rise [-]
        self.natural = {s: float(np.sqrt(np.mean((b - a) ** 2)) / np.sqrt(np.mean(a**2))) for s, (a, b) in self.std.items()}
        d = np.concatenate([(b - a).ravel() for a, b in self.std.values()])
        y = np.concatenate([a.ravel() for a, _ in self.std.values()])
        self.natural["both"] = float(np.sqrt(np.mean(d**2)) / np.sqrt(np.mean(y**2)))

    def _pair(self, scheme, power_scale, sites, times):
        from imutherm.studies.correlation.form_generator import form_pair
        geo = self.geo[scheme]
        values = dict(self.truth, **({"power_scale": power_scale} if power_scale != 1.0 else {}))
        path = None
        if PAIR_CACHE is not None:  # keyed by everything that determines the pair, never by the rules
            key = repr((self.form, self.kind, self.seed, scheme, float(power_scale), tuple(sites),
                        np.round(np.asarray(times, float), 6).tolist(), sorted(values.items()), self.lid,
                        repr(self.models.options), repr(self.gen), self.gen_mesh, FEM_MESH_MM, FEM_MIN_CELLS))
            path = PAIR_CACHE / f"pair_{hashlib.sha256(key.encode()).hexdigest()[:24]}.npz"
            if path.exists():
                with np.load(path) as z:
                    return z["inversion"], z["generator"]
        a, b = form_pair(geo, values, self.models.options, self.gen, FEM_MESH_MM, FEM_MIN_CELLS, self.gen_mesh,
                         {s: geo.sites[s] for s in sites}, times, self.lid)
        if path is not None:
            tmp = path.with_suffix(".tmp.npz")
            np.savez(tmp, inversion=a, generator=b)
            tmp.replace(path)
        return a, b

    def run(self, level: float, scheme: str, rng, power_scale=1.0, sites=FEM_SITES, times=None, name=None):
        """A measured file: the inversion-form rise plus k x the form's difference, k set on the standard file."""
        a0, b0 = self.std[scheme]
        k = level / max(self.natural["both"], 1e-12)
        if times is None:
            times, (a, b) = np.linspace(0.0, 1500.0, 40), (a0, b0)
        else:
            a, b = self._pair(scheme, power_scale, sites, times)
        y = a + k * (b - a) + rng.normal(0.0, NOISE_K, a.shape)
        return MeasuredRun(name or f"{scheme}.csv", scheme, 70.0, power_scale, 0.0, "die", tuple(sites),
                           np.asarray(times, float), 70.0 + y, tuple(range(len(times))))

    def signature(self) -> float | None:
        """RMS [K] / noise of what the hidden one changes at the standard files (the reduced models; a lid load:
        the FEM pair's inversion-form rise with and without it is not computed, None)."""
        if self.value is None or self.lid is not None:
            return None
        from imutherm.studies.correlation.forward_model import ForwardModel
        from imutherm.unit import knobs
        t = np.linspace(0.0, 1500.0, 40)
        runs = tuple(MeasuredRun(f"{s}.csv", s, 70.0, 1.0, 0.0, "die", FEM_SITES, t, np.zeros((40, 6)),
                                 tuple(range(40))) for s in SCHEMES)
        fwd = ForwardModel(runs, self.models.roms, self.models.geometries)
        base = dict(self.truth)
        base[self.kind] = knobs.nominal_values(self.geo["air"], self.models.options).get(self.kind, None)
        if base[self.kind] is None:
            base.pop(self.kind)
        d = np.concatenate([(fwd.rise(i, self.truth) - fwd.rise(i, base)).ravel() for i in range(len(runs))])
        return float(np.sqrt(np.mean(d**2)) / NOISE_K)


def fem_case(case: FemCase, level: float, models) -> dict:
    """Correlate one FEM case at one level, and for an ambiguous verdict run the proposed experiment: one row."""
    rng = np.random.default_rng([case.seed, int(round(1000 * level))])
    runs = [case.run(level, s, rng) for s in SCHEMES]
    t0 = time.perf_counter()
    res = correlate(runs, models=models, candidates=FEM_CANDIDATES, rerun=False)
    j = result_json(res)
    rise = float(np.sqrt(np.mean(np.concatenate([r.rise_K.ravel() for r in runs]) ** 2)))
    plain = res.retune_plain or res.retune
    row = {"kind": case.kind, "value": case.value, "level": level, "seed": case.seed, **_verdict_fields(res, j),
           "signature_sigmas": case.signature(), "natural_form_level": case.natural, "rms_rise_K": rise,
           "retune_rms_K": plain.rms_K, "noise_K": res.noise_K,
           "retuned": {k: float(v) for k, v in plain.values.items()}}
    if res.verdict == "ambiguous" and res.next_experiment:
        from imutherm.studies.correlation.next_experiment import DESIGN_SAMPLES
        nx = res.next_experiment
        tn = np.linspace(0.0, nx["duration_s"], DESIGN_SAMPLES + 1)[1:]
        extra = case.run(level, nx["scheme"], rng, nx["power_scale"], tuple(nx["probes"]), tn, "next.csv")
        again = correlate(runs + [extra], models=models, candidates=FEM_CANDIDATES, rerun=False)
        row["settled_first"] = result_json(again)["named_first"]
        row["settled_verdict"] = again.verdict
    row["seconds"] = time.perf_counter() - t0
    return row


def summarise(rows: list) -> dict:
    """The campaign's figures per level, by the rules of the module docstring."""
    out = {}
    for level in sorted({r["level"] for r in rows}):
        rs = [r for r in rows if r["level"] == level]
        strong = [r for r in rs if r["value"] is not None and (r["signature_sigmas"] or 0.0) >= STRONG_SIGMAS]
        right = [r for r in strong if r["named_first"] == r["kind"] or r["settled_first"] == r["kind"]]
        nulls = [r for r in rs if r["value"] is None]
        ool = [r for r in rs if r["kind"] == "lid_heat_load"]
        false = [r for r in nulls if r["named_effects"] or r["findings"]]
        amb = [r for r in rs if r["verdict"] == "ambiguous" and r["value"] is not None]
        settled = [r for r in amb if r["settled_first"] == r["kind"]]
        worse = [r for r in rs if r["written_heldout_K"] is not None and r["nominal_heldout_K"] is not None
                 and r["written_heldout_K"] > r["nominal_heldout_K"] * (1 + 1e-9)]
        out[f"{100 * level:g}%"] = {
            "strong_named_right": f"{len(right)}/{len(strong)}", "null_false_names": f"{len(false)}/{len(nulls)}",
            "ambiguous_settled_right": f"{len(settled)}/{len(amb)}", "written_worse_than_nominal": f"{len(worse)}/{len(rs)}",
            **({"null_ambiguous_sets": f"{sum(bool(r['ambiguous_set']) for r in nulls)}/{len(nulls)}",
                "null_ambiguous_settled_to_nothing": sum(bool(r['ambiguous_set']) and r.get('settled_verdict') is not None
                                                         and not r['settled_first'] for r in nulls)}
               if any(r["ambiguous_set"] for r in nulls) else {}),
            **({"out_of_library_false_names": f"{sum(bool(r['named_effects'] or r['findings']) for r in ool)}/{len(ool)}",
                "out_of_library_verdicts": [r["verdict"] for r in ool]} if ool else {}),
            **({"null_retune_residual_pct_of_rise": [round(100 * np.sqrt(max(r["retune_rms_K"]**2 - r["noise_K"]**2, 0.0))
                                                           / r["rms_rise_K"], 2) for r in nulls]}
               if nulls and "rms_rise_K" in nulls[0] else {}),
            "misses": [(r["kind"], r["verdict"], r["named_first"], r["settled_first"]) for r in strong if r not in right]}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", type=int, default=4, help="cases per hidden kind and level")
    ap.add_argument("--seed", type=int, default=58)
    ap.add_argument("--out", required=True)
    ap.add_argument("--generator", choices=("toy", "fem"), default="toy")
    ap.add_argument("--form", choices=("layered", "cavity_law", "grid", "nuisance"), default="layered",
                    help="--generator fem: the generator's one other form")
    ap.add_argument("--kinds", nargs="*", default=None, help="--generator fem: only these hidden kinds")
    ap.add_argument("--pair-cache", default=None, help="--generator fem: directory caching the FEM pairs")
    ap.add_argument("--levels", nargs="*", type=float, default=None,
                    help="form error levels as fractions of the rise (default 0.02 0.05 0.10)")
    ap.add_argument("--pairs-only", action="store_true",
                    help="--generator fem with --pair-cache: only generate the standard files' FEM pairs (no correlation)")
    ap.add_argument("--table", nargs="*", default=None, help="print the markdown table of these forms_fem_*.json, stop")
    args = ap.parse_args(argv)
    if args.table is not None:
        print(table(args.table))
        return 0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.generator == "fem":
        return _main_fem(args, out)
    from _toy_reduced import toy_models
    models = toy_models()
    rows = []
    for level in (tuple(args.levels) if args.levels else LEVELS):
        for kind in KINDS:
            for c in range(args.cases):
                seed = args.seed * 10000 + list(KINDS).index(kind) * 100 + c  # the same truth at every level
                r = one_case(kind, level, seed, models)
                rows.append(r)
                print(f"{100 * level:>4g}% {kind:<18} sig {r['signature_sigmas'] or 0:6.1f} -> {r['verdict']:<14} "
                      f"{r['named_first'] or '-':<18} settled {r['settled_first'] or '-'} ({r['seconds']:.0f} s)",
                      flush=True)
                write_json(out / "forms_rows.json", rows)
    summary = summarise(rows)
    write_json(out / "forms_campaign.json", {"rows": rows, "summary": summary, "args": vars(args)})
    print(json.dumps(summary, indent=1))
    return 0


def table(paths) -> str:
    """A markdown table of FEM campaigns (``forms_fem_<form>.json`` or its ``_rows.json``): one row per form and
    level, the figures by :func:`summarise`."""
    head = ("| form | natural form error | level | strong named right | null false names | null ambiguous sets "
            "| out of library named | ambiguous settled right | written worse than nominal | null re-tune residual |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for p in paths:
        d = json.loads(Path(p).read_text())
        rows = d["rows"] if isinstance(d, dict) else d  # a campaign's file or its rows file
        nat = np.median([r["natural_form_level"]["both"] for r in rows])
        for lev, x in summarise(rows).items():
            lines.append(f"| {rows[0]['form']} | {100 * nat:.2f} % | {lev} | {x['strong_named_right']} | "
                         f"{x['null_false_names']} | {x.get('null_ambiguous_sets', '0/' + x['null_false_names'].split('/')[1])} | "
                         f"{x.get('out_of_library_false_names', '-')} | {x['ambiguous_settled_right']} | "
                         f"{x['written_worse_than_nominal']} | "
                         f"{', '.join(f'{v:g} %' for v in x.get('null_retune_residual_pct_of_rise', [])) or '-'} |")
    return "\n".join(lines)


def _main_fem(args, out: Path) -> int:
    """The FEM campaign of one form (module docstring): each case generated once, correlated at every level."""
    global PAIR_CACHE
    if args.pair_cache:
        PAIR_CACHE = Path(args.pair_cache)
        PAIR_CACHE.mkdir(parents=True, exist_ok=True)
    levels = tuple(args.levels) if args.levels else LEVELS
    from imutherm.studies.correlation import build_models
    models = build_models(tuple((s, 70.0) for s in SCHEMES), mesh_size_mm=FEM_MESH_MM, min_cells=FEM_MIN_CELLS)
    kinds = args.kinds or list(FEM_KINDS)
    rows = []
    for kind in kinds:
        for c in range(args.cases):
            seed = args.seed * 10000 + list(FEM_KINDS).index(kind) * 100 + c  # the same truth under every form
            t0 = time.process_time()
            case = FemCase(kind, args.form, seed, models)
            t_gen = time.process_time() - t0
            if args.pairs_only:
                print(f"{args.form} {kind:<18} seed {seed}: pairs cached ({t_gen:.0f} CPU-s)", flush=True)
                continue
            for level in levels:
                r = fem_case(case, level, models)
                r.update(form=args.form, gen_cpu_s=t_gen)
                rows.append(r)
                print(f"{args.form} {100 * level:>4g}% {kind:<18} sig {r['signature_sigmas'] or 0:6.1f} -> "
                      f"{r['verdict']:<14} {r['named_first'] or '-':<18} settled {r['settled_first'] or '-'} "
                      f"(natural {100 * case.natural['both']:.2f} %, gen {t_gen:.0f} s, {r['seconds']:.0f} s)",
                      flush=True)
                write_json(out / f"forms_fem_{args.form}_rows.json", rows)
    if args.pairs_only:
        return 0
    summary = summarise(rows)
    write_json(out / f"forms_fem_{args.form}.json", {"rows": rows, "summary": summary, "args": vars(args)})
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
