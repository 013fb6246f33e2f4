"""The correlation's selection logic under a gross model-form error, on the toy reduced models (seconds per case).

The toy (``tests/_toy_reduced.py``: closed-form site rises, each effect a fixed site pattern per scheme) is
inverted as ``correlate`` does by default (the cavity's emissivity re-tuned, not a candidate; the discrepancy
term where the library does not explain the data), on cases with a smooth form error of the model (a gain
error of 12 % of the rise in air and 5 % or 1 % in grease, or 20 % / 8 %, with a 150 s response) and one
library effect hidden (a poor bond line, grease only; a 5 V regulator power error, both schemes) or none.
Prints per case the verdict, the named effects and the first step's three best candidates (ΔC over the
re-tuned model, held-out change, :func:`~imutherm.studies.correlation.heldout_worse_z`), then the counts:
strong effects named (hidden first), nulls naming no library effect. This measures how the verdict's rules
behave when the form error and the effect are of one size; the FEM campaign (``bench_correlation.py
--model-form cavity-law``) is the test on data of another form.

    python benchmarks/bench_correlation_toy.py --seeds 1 2
    python benchmarks/bench_correlation_toy.py --term always --cavity-emissivity-as-effect   # the other settings
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from _toy_reduced import toy_models, toy_runs  # noqa: E402

from imutherm.studies.correlation import correlate, heldout_worse_z  # noqa: E402

#: the toy's candidates as correlate offers them by default (the cavity's emissivity re-tuned)
CANDIDATES = ("power@reg_5v", "power@processor", "contact@bond")
NUISANCE = {"k_board_W_mK": 18.5, "mount_h_W_m2K": 470.0, "convection_scale": 1.05}


def form(amp_air: float, amp_grease: float):
    """A smooth form error: the measured gain amp x the site's rise above the model, 150 s response."""
    return lambda s, t: (amp_air if s == "air" else amp_grease) * np.linspace(17, 8, 6) * (1 - np.exp(-t / 150))[:, None]


CASES = (("contact@bond", 150.0, (0.12, 0.05)), ("contact@bond", 300.0, (0.12, 0.05)),
         ("contact@bond", 150.0, (0.12, 0.01)), ("power@reg_5v", 0.3, (0.12, 0.05)),
         ("power@reg_5v", 0.6, (0.12, 0.05)), ("none", None, (0.12, 0.05)), ("none", None, (0.12, 0.01)),
         ("none", None, (0.20, 0.08)))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", type=int, nargs="*", default=[1, 2])
    p.add_argument("--term", choices=("auto", "always"), default="auto",
                   help="the discrepancy term: as correlate's default (auto) or always")
    p.add_argument("--cavity-emissivity-as-effect", action="store_true",
                   help="offer the cavity's emissivity as a candidate (default: re-tuned)")
    args = p.parse_args()
    models = toy_models()
    cands = CANDIDATES + (("cavity_emissivity",) if args.cavity_emissivity_as_effect else ())
    disc = "auto" if args.term == "auto" else True
    named = first = strong = nulls = null_ok = 0
    for seed in args.seeds:
        for hidden, value, (fa, fg) in CASES:
            vals = dict(NUISANCE) if hidden == "none" else {**NUISANCE, hidden: value}
            runs = toy_runs(vals, np.random.default_rng(seed), form(fa, fg))
            res = correlate(runs, models=models, candidates=cands, rerun=False, discrepancy=disc)
            top = ""
            if res.steps:
                base = res.steps[0]["base"]
                top = " | " + ", ".join(f"{f.name} ΔC {base.aicc - f.aicc:.1f} held-out "
                                        f"{f.heldout_rms_K / base.heldout_rms_K - 1:+.1%} z {heldout_worse_z(f, base):.1f}"
                                        for f in res.steps[0]["ranking"][:3])
            print(f"seed {seed} {hidden:<14} {value!s:<6} form {fa:.0%}/{fg:.0%}: {res.verdict:<12} "
                  f"{'+'.join(res.named_effects) or '-'}{top}", flush=True)
            if hidden == "none":
                nulls += 1
                null_ok += res.verdict != "effect"
            else:
                strong += 1
                named += hidden in res.named_effects
                first += res.named_effects[:1] == (hidden,)
    print(f"hidden among named {named}/{strong}, first {first}/{strong}; nulls naming no library effect "
          f"{null_ok}/{nulls}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
