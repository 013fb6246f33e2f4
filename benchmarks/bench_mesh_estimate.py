"""Benchmark: the mesh-error estimate's refined solve, matrix-free against assembled, paired per unit and scheme.

For the reference unit (air, grease, potted) and shared boards imported as a user imports them (``imutherm import``
as ``bench_board_solve.py`` does; boards from ``examples/boards/``, copies of ``$IMUTHERM_SHARED_DATA/boards``,
sources in ``examples/boards/SOURCES.md``), each scheme's steady solve is followed by its refined solve, once
assembled (:func:`imutherm.thermal.refinement.refined_steady`) and once matrix-free
(:func:`imutherm.thermal.mesh_estimate.refined_steady_matrix_free`), each in a process of its own (its peak memory
is the process's, the default-mesh solve's included). Reported per site: the refined grid's change
``d = T(h/2) - T(h)`` (assembled), the matrix-free value's difference from it, the answer's bound, and the
effectivity ``d_k / d`` of the matrix-free CG truncated after k steps (what a cheaper, truncated estimate would
give; a two-level step is a dual-weighted residual estimate with an approximate dual).

    python benchmarks/bench_mesh_estimate.py [--write]               # reference unit + 2 boards, ~10 min idle
    python benchmarks/bench_mesh_estimate.py --boards                # the reference unit only

``--write`` records the printout in ``docs/benchmarks/tables/mesh_estimate.txt`` (``benchmarks/_record.py``).
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BOARDS = ROOT / "examples" / "boards"
sys.path.insert(0, str(Path(__file__).resolve().parent))
TRUNCATED = (2, 4, 6, 8)


def case(layout: str, scheme: str, mode: str) -> dict:
    """One unit, scheme and refined solve (``mf`` or ``assembled``) in this process: figures as a dict."""
    import numpy as np

    from imutherm.studies.thermal.thermal_study import refined_problem, run_scheme
    from imutherm.thermal.mesh_estimate import refined_steady_matrix_free
    from imutherm.thermal.refinement import refined_steady

    kept = {}
    res = run_scheme(None if layout == "reference" else layout, scheme, keep=kept, transient=False)
    st = res.steady
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    c0, t0 = time.process_time(), time.perf_counter()
    fp, prolong, probes, coarse, cmax = refined_problem(res)
    history = []
    if mode == "mf":
        est = refined_steady_matrix_free(fp, st.T_C, prolong, kept["preconditioner"], probes, coarse, cmax,
                                         history=history)
    else:
        est = refined_steady(fp, st.problem, st.T_C, prolong, probes, coarse, cmax, coarse_pc=kept["preconditioner"])
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    start = prolong @ np.asarray(st.T_C)   # the sites' prolonged values: history is the change from them
    from imutherm.thermal.probes import named_probes
    _, Pm = named_probes(fp.grid, probes)
    p0 = Pm @ start
    return {"layout": layout, "scheme": scheme, "mode": mode, "nodes": int(res.grid.n_nodes),
            "fine_nodes": est.fine_nodes, "cpu_s": cpu, "wall_s": wall, "rss_before_MB": rss0, "rss_peak_MB": rss1,
            "cg_steps": est.cg_steps, "names": list(est.names), "coarse_C": est.coarse_C.tolist(),
            "fine_C": est.fine_C.tolist(), "bound_K": est.answer_error_K.tolist(),
            "history_K": [(p0 + h - np.asarray(coarse)).tolist() for h in history]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--boards", nargs="*", default=["proves-fc-v4c", "cube-main"])
    ap.add_argument("--case", nargs=3, metavar=("LAYOUT", "SCHEME", "MODE"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.case:
        print(json.dumps(case(*args.case)))
        return 0
    from bench_board_solve import SITES
    from bench_import import run

    work = Path(tempfile.mkdtemp(prefix="bench_mesh_estimate_"))
    units = [("reference", s) for s in ("air", "grease", "potted")]
    for name in args.boards:
        (work / f"{name}.kicad_pcb").write_bytes(gzip.decompress((BOARDS / f"{name}.kicad_pcb.gz").read_bytes()))
        run([sys.executable, "-m", "imutherm.cli", "import", f"{name}.kicad_pcb", "--powers",
             str(BOARDS / f"{name}_powers.csv"), "--site", SITES[name], "--out",
             f"{name}.toml"], work)
        units.append((str(work / f"{name}.toml"), "air"))
    print(f"# bench_mesh_estimate, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load before "
          f"{os.getloadavg()[0]:.1f}", flush=True)
    rows = []
    for layout, scheme in units:
        pair = {}
        for mode in ("assembled", "mf"):
            out = subprocess.run([sys.executable, __file__, "--case", layout, scheme, mode], capture_output=True,
                                 text=True, cwd=work, env={**os.environ, "OMP_NUM_THREADS": "1"})
            if out.returncode:
                raise SystemExit(out.stderr[-3000:])
            pair[mode] = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(pair)
        a, m = pair["assembled"], pair["mf"]
        unit = Path(layout).stem if layout != "reference" else "reference"
        print(f"\n## {unit} / {scheme}: {a['nodes']:,} -> {a['fine_nodes']:,} nodes; refined solve assembled "
              f"{a['cpu_s']:.2f} CPU-s, {a['cg_steps']} CG steps, process peak {a['rss_peak_MB']:.0f} MB "
              f"(+{a['rss_peak_MB'] - a['rss_before_MB']:.0f}); matrix-free {m['cpu_s']:.2f} CPU-s, "
              f"{m['cg_steps']} CG steps, peak {m['rss_peak_MB']:.0f} MB (+{m['rss_peak_MB'] - m['rss_before_MB']:.0f})")
        print(f"{'site':12s} {'d [K]':>8s} {'mf - as [K]':>12s} {'bound [K]':>10s} {'|mf-as|/bound':>14s}  "
              + "  ".join(f"eff@{k:<2d}" for k in TRUNCATED))
        hist = m["history_K"]
        for i, n in enumerate(a["names"]):
            d = a["fine_C"][i] - a["coarse_C"][i]
            diff = m["fine_C"][i] - a["fine_C"][i]
            effs = []
            for k in TRUNCATED:
                if n == "hot spot" or k > len(hist) or abs(d) < 1e-3:
                    effs.append("    - ")
                else:
                    effs.append(f"{hist[k - 1][i] / d:6.2f}")
            ratio = abs(diff) / a["bound_K"][i] if a["bound_K"][i] > 0 else float("nan")
            print(f"{n:12s} {d:+8.4f} {diff:+12.5f} {a['bound_K'][i]:10.4f} {ratio:14.3f}  " + "  ".join(effs))
    print(f"\n# load after {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    if "--case" in sys.argv:
        sys.exit(main())
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "mesh_estimate", "the mesh-error estimate's refined solve, matrix-free vs assembled"))
