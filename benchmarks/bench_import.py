"""Benchmark of real boards at real-board scale: import, compare and a steady solve, against the
reference unit on the same machine, side by side.

* ``imutherm import`` of the two shared boards (``examples/boards/``: openuav, KiCad 7, 80 footprints;
  drone-fc, KiCad 5, 78 footprints) with their powers, heights and sites, and of a **316-footprint panel**
  built from them (two of each on one 100 x 100 mm 4-layer board: the ``80-270 footprints a board`` scale);
* ``imutherm compare`` (the main job, default settings) on the reference unit and on each single-board unit:
  wall time, CPU seconds (user + sys of the command and its workers) and peak resident memory of the process
  tree; target: each imported unit within 2x the reference unit's time and memory;
* ``imutherm solve --scheme grease`` (steady) on the reference unit and on the panel; target within 3x.

The runs are interleaved (reference, then each board, ``--repeat`` times) so a drift of the machine's speed
hits both sides alike; ratios are of the medians.

    python benchmarks/bench_import.py                 # everything (~6-10 min on 2 idle cores)
    python benchmarks/bench_import.py --repeat 2 --skip-compare
"""

from __future__ import annotations

import argparse
import copy
import gzip
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
import _record  # noqa: E402  (benchmarks/_record.py)
from bench_study import _tree_memory_mb  # noqa: E402

COMPARE_RATIO, SOLVE_RATIO = 2.0, 3.0


def run(cmd: list, cwd: Path) -> dict:
    """Run ``cmd``: wall [s], CPU [s] (its process tree), peak tree RSS [MB], output."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    peak = 0.0
    while proc.poll() is None:
        peak = max(peak, _tree_memory_mb(proc.pid)[0])
        time.sleep(0.1)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = proc.stdout.read()
    if proc.returncode:
        raise SystemExit(f"{' '.join(map(str, cmd))} failed ({proc.returncode}):\n{out[-3000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall": wall, "cpu": cpu, "mb": peak, "out": out}


def panel_board(folder: Path) -> Path:
    """A 100 x 100 mm 4-layer board holding two copies of each shared board's footprints (316), each copy's
    references prefixed (P1-U1 ...), with the powers and heights CSVs of the copies."""
    from imutherm.ecad.sexpr import Quoted, child, children, dump_sexpr, parse_sexpr

    trees = {n: parse_sexpr(gzip.decompress((BOARDS / f"{n}.kicad_pcb.gz").read_bytes()).decode())
             for n in ("openuav", "drone-fc")}
    ou = trees["openuav"]
    head = [c for c in ou if not (isinstance(c, list) and c and c[0] in
                                  ("footprint", "module", "gr_line", "gr_arc", "gr_rect", "gr_circle", "gr_poly",
                                   "segment", "via", "zone", "arc", "gr_text"))]
    placed = []
    copies = (("drone-fc", 0.0, 0.0, "P1-"), ("drone-fc", 50.0, 0.0, "P2-"),
              ("openuav", 7.0, 57.0, "P3-"), ("openuav", 57.0, 57.0, "P4-"))
    powers, heights = ["reference,power_W,source"], ["reference,height_mm,source"]
    for name, dx, dy, prefix in copies:
        tree = trees[name]
        xs = [p[1] for node in children(tree, "gr_line") + children(tree, "gr_arc") if child(node, "layer")
              and str(child(node, "layer")[1]) == "Edge.Cuts" for p in (child(node, "start"), child(node, "end"))]
        ys = [p[2] for node in children(tree, "gr_line") + children(tree, "gr_arc") if child(node, "layer")
              and str(child(node, "layer")[1]) == "Edge.Cuts" for p in (child(node, "start"), child(node, "end"))]
        x0, y0 = min(xs), min(ys)
        for fp in children(tree, "footprint") + children(tree, "module"):
            fp = list(fp)
            if fp[0] == "module":   # the KiCad 5 dialect's items read the same; the panel is written as KiCad 7
                fp[0] = "footprint"
            for i, c in enumerate(fp):
                if isinstance(c, list) and c and c[0] == "at":
                    fp[i] = ["at", c[1] - x0 + dx + 100.0, c[2] - y0 + dy + 100.0] + c[3:]
                if isinstance(c, list) and c and c[0] == "fp_text" and c[1] == "reference":
                    fp[i] = c[:2] + [Quoted(prefix + str(c[2]))] + c[3:]
                if isinstance(c, list) and c and c[0] == "layer":
                    fp[i] = ["layer", Quoted(str(c[1]))]
            placed.append(fp)
        for csv, rows in ((f"{name}_powers.csv", powers), (f"{name}_heights.csv", heights)):
            for line in (BOARDS / csv).read_text().splitlines():
                if line and not line.startswith(("#", "reference")):
                    rows.append(prefix + line)
        if name == "openuav":   # the regulators' losses as the electrical design gives them (rounded)
            rows_p = {"U4": 0.0424, "U7": 0.0516, "U5": 0.0015}
            powers += [f"{prefix}{r},{w},openuav_electrical.toml at 11.1 V" for r, w in rows_p.items()]
    edge = [["gr_rect", ["start", 100.0, 100.0], ["end", 200.0, 200.0], ["layer", Quoted("Edge.Cuts")],
             ["width", 0.05]]]
    text = dump_sexpr(head + edge + placed)
    path = folder / "panel.kicad_pcb"
    path.write_text(text)
    (folder / "panel_powers.csv").write_text("\n".join(powers) + "\n")
    (folder / "panel_heights.csv").write_text("\n".join(heights) + "\n")
    return path


def _extent(fp) -> tuple:
    """(x0, y0, x1, y1) [mm] of a footprint's courtyard (else fab, else pads) in its own frame (KiCad y down)."""
    from imutherm.ecad.sexpr import child

    for layer in (".CrtYd", ".Fab"):
        pts = [(c[1], c[2]) for g in fp[1:] if isinstance(g, list) and g and str(g[0]).startswith("fp_")
               and child(g, "layer") and str(child(g, "layer")[1]).endswith(layer)
               for c in g[1:] if isinstance(c, list) and c and c[0] in ("start", "end")]
        if pts:
            xs, ys = zip(*pts)
            return min(xs), min(ys), max(xs), max(ys)
    pads = []
    for p in fp[1:]:
        if isinstance(p, list) and p and p[0] == "pad":
            at, size = child(p, "at"), child(p, "size")
            quarter = round((at[3] if len(at) > 3 else 0.0) / 90.0) % 2   # local pad angle (absolute minus the part's)
            w, h = (size[2], size[1]) if quarter else (size[1], size[2])
            pads.append((at[1], at[2], w, h))
    return (min(x - w / 2 for x, _, w, _ in pads), min(y - h / 2 for _, y, _, h in pads),
            max(x + w / 2 for x, _, w, _ in pads), max(y + h / 2 for _, y, _, h in pads))


def dense_board(folder: Path, copies: int = 5, fill: float = 0.8) -> Path:
    """A board of real density: the footprints of ``copies`` shared boards (alternately openuav and drone-fc;
    their mounting holes and wire pads left out, four corner holes added) re-placed at rotation 0 by shelf
    packing onto a square board whose courtyards cover ``fill`` of it, with the copies' powers and heights."""
    from imutherm.ecad.sexpr import Quoted, child, children, dump_sexpr, parse_sexpr

    trees = {n: parse_sexpr(gzip.decompress((BOARDS / f"{n}.kicad_pcb.gz").read_bytes()).decode())
             for n in ("openuav", "drone-fc")}
    head = [c for c in trees["openuav"] if not (isinstance(c, list) and c and c[0] in
            ("footprint", "module", "gr_line", "gr_arc", "gr_rect", "gr_circle", "gr_poly", "segment", "via", "zone",
             "arc", "gr_text"))]
    items, powers, heights = [], ["reference,power_W,source"], ["reference,height_mm,source"]
    for k in range(copies):
        name = ("openuav", "drone-fc")[k % 2]
        prefix = f"P{k + 1}-"
        for fp in children(trees[name], "footprint") + children(trees[name], "module"):
            lib = str(fp[1])
            ref = next(str(c[2]) for c in fp if isinstance(c, list) and c[:2] == ["fp_text", "reference"])
            if "MountingHole" in lib or "smallpad" in lib:
                continue
            fp = copy.deepcopy(fp)   # each copy its own (the pads' angles are changed below)
            fp[0] = "footprint"
            rot = 0.0
            for i, c in enumerate(fp):
                if isinstance(c, list) and c and c[0] == "at":
                    rot = c[3] if len(c) > 3 else 0.0
                    fp[i] = ["at", 0.0, 0.0, 0.0]
                elif isinstance(c, list) and c and c[0] == "fp_text" and c[1] == "reference":
                    fp[i] = c[:2] + [Quoted(prefix + ref)] + c[3:]
                elif isinstance(c, list) and c and c[0] == "layer":
                    fp[i] = ["layer", Quoted(str(c[1]))]
            for c in fp:   # pad angles are absolute: take the old footprint rotation out
                if isinstance(c, list) and c and c[0] == "pad":
                    at = child(c, "at")
                    if at is not None and len(at) > 3:
                        at[3] = at[3] - rot
            items.append(fp)
        for csv, rows in ((f"{name}_powers.csv", powers), (f"{name}_heights.csv", heights)):
            for line in (BOARDS / csv).read_text().splitlines():
                if line and not line.startswith(("#", "reference")):
                    rows.append(prefix + line)
        if name == "openuav":   # the regulators' losses as openuav_electrical.toml gives them at 11.1 V
            powers += [f"{prefix}{r},{w},openuav_electrical.toml at 11.1 V"
                       for r, w in {"U4": 0.0424, "U7": 0.0516, "U5": 0.0015}.items()]
    rects = [(_extent(fp), fp) for fp in items]
    area = sum((e[2] - e[0] + 0.3) * (e[3] - e[1] + 0.3) for e, _ in rects)
    side = round((area / fill) ** 0.5 + 8.0, 1)   # + a 4 mm margin each side for the corner holes
    x, y, row = 4.0, 4.0, 0.0
    for (x0, y0, x1, y1), fp in sorted(rects, key=lambda r: -(r[0][3] - r[0][1])):
        w, h = x1 - x0 + 0.3, y1 - y0 + 0.3
        if x + w > side - 4.0:
            x, y, row = 4.0, y + row, 0.0
        at = child(fp, "at")
        at[1], at[2] = 100.0 + x - x0 + 0.15, 100.0 + y - y0 + 0.15
        x, row = x + w, max(row, h)
    if y + row > side - 4.0:
        raise SystemExit(f"dense board: the packing needs {y + row:.1f} mm of a {side:.1f} mm board")
    holes = [["footprint", Quoted("MountingHole:MountingHole_3.2mm_M3"), ["layer", Quoted("F.Cu")],
              ["at", 100.0 + cx, 100.0 + cy], ["fp_text", "reference", Quoted(f"H{i + 1}"), ["at", 0.0, 0.0]],
              ["attr", "exclude_from_bom"], ["pad", Quoted(""), "np_thru_hole", "circle", ["at", 0.0, 0.0],
                                            ["size", 3.2, 3.2], ["drill", 3.2], ["layers", Quoted("*.Cu")]]]
             for i, (cx, cy) in enumerate(((2.0, 2.0), (side - 2.0, 2.0), (2.0, side - 2.0), (side - 2.0, side - 2.0)))]
    edge = [["gr_rect", ["start", 100.0, 100.0], ["end", 100.0 + side, 100.0 + side], ["layer", Quoted("Edge.Cuts")],
             ["width", 0.05]]]
    path = folder / "dense.kicad_pcb"
    path.write_text(dump_sexpr(head + edge + holes + items))
    (folder / "dense_powers.csv").write_text("\n".join(powers) + "\n")
    (folder / "dense_heights.csv").write_text("\n".join(heights) + "\n")
    print(f"dense board: {len(items) + 4} footprints on {side:.1f} x {side:.1f} mm "
          f"({(len(items) + 4) / side**2 * 100:.1f} per cm^2)")
    return path


def _cells(work: Path, what: str, name: str) -> str:
    """The mesh of a run, from its result file (compare: the grease scheme's)."""
    import json

    if what == "solve":
        mesh = json.loads((work / f"solve_{name}_0" / "result.json").read_text())["mesh"]
    else:
        mesh = json.loads((work / f"compare_{name}_0" / "summary.json").read_text())["mesh"]["grease"]
    return f"{mesh['cells']:,} cells"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=1, help="interleaved runs of each command (medians reported)")
    ap.add_argument("--skip-compare", action="store_true", help="only the imports and the steady solves")
    args = ap.parse_args(argv)
    os.environ["IMUTHERM_CACHE"] = "off"   # every repeat solves: none read from the disk cache (imutherm.cache)
    work = Path(tempfile.mkdtemp(prefix="bench_import_"))
    imu = [sys.executable, "-m", "imutherm.cli"]
    for name in ("openuav", "drone-fc"):
        (work / f"{name}.kicad_pcb").write_bytes(gzip.decompress((BOARDS / f"{name}.kicad_pcb.gz").read_bytes()))
    panel = panel_board(work)
    dense = dense_board(work)
    imports = {
        "openuav": ["openuav.kicad_pcb", "--powers", BOARDS / "openuav_powers.csv", "--electrical",
                    BOARDS / "openuav_electrical.toml", "--heights", BOARDS / "openuav_heights.csv", "--site", "U3=imu"],
        "drone-fc": ["drone-fc.kicad_pcb", "--powers", BOARDS / "drone-fc_powers.csv", "--heights",
                     BOARDS / "drone-fc_heights.csv", "--site", "U2=imu"],
        "panel": [panel.name, "--powers", work / "panel_powers.csv", "--heights", work / "panel_heights.csv",
                  "--site", "P3-U3=imu"],
        "dense": [dense.name, "--powers", work / "dense_powers.csv", "--heights", work / "dense_heights.csv",
                  "--site", "P1-U3=imu"],
    }
    layouts = {"reference": "imu_reference"}
    for name, extra in imports.items():
        r = run(imu + ["import", *map(str, extra), "--out", f"{name}.toml"], work)
        layouts[name] = str(work / f"{name}.toml")
        summary = next(line for line in r["out"].splitlines() if "footprints:" in line)
        print(f"import {name}: {r['wall']:.2f} s wall, {r['cpu']:.2f} CPU-s, {r['mb']:.0f} MB; {summary}")
    results = {}
    plan = [] if args.skip_compare else [("compare", n, imu + ["compare", layouts[n], "--no-progress"])
                                         for n in ("reference", "openuav", "drone-fc")]
    plan += [("solve", n, imu + ["solve", layouts[n], "--scheme", "grease"]) for n in ("reference", "dense", "panel")]
    for i in range(args.repeat):
        for what, name, cmd in plan:
            r = run(cmd + ["--out", f"{what}_{name}_{i}"], work)
            results.setdefault((what, name), []).append(r)
            print(f"[{i + 1}/{args.repeat}] {what} {name}: {r['wall']:.1f} s wall, {r['cpu']:.1f} CPU-s, "
                  f"{r['mb']:.0f} MB peak", flush=True)
    ok = True
    print(f"\n{'command':<8} {'unit':<10} {'wall [s]':>9} {'CPU [s]':>8} {'peak [MB]':>10} {'x ref wall':>10} "
          f"{'x ref CPU':>9} {'x ref MB':>8}  target")
    for (what, name), runs in results.items():
        med, ratios = _record.paired(runs, results[(what, "reference")])
        limit = COMPARE_RATIO if what == "compare" else SOLVE_RATIO
        passed = name == "reference" or all(x <= limit for x in ratios)
        ok &= passed
        cells = _cells(work, what, name)
        print(f"{what:<8} {name:<10} {med['wall']:9.1f} {med['cpu']:8.1f} {med['mb']:10.0f} {ratios[0]:10.2f} "
              f"{ratios[1]:9.2f} {ratios[2]:8.2f}  {'' if name == 'reference' else f'<= {limit:g}x '}"
              f"{'' if name == 'reference' else ('PASS' if passed else 'FAIL')} {cells}")
    print(f"\n{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the end; work folder {work}")
    return 0 if ok else 1


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "import",
                         "real boards at real-board scale: imports, compare and solves against the reference unit"))
