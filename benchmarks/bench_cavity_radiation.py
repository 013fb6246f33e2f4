"""Cost and effect of the cavity radiation laws on the reference unit (cavity radiation is also one of the
correlation's candidate effects).

Usage::

    python benchmarks/bench_cavity_radiation.py [--scheme air] [--mesh-size 2.0]
        [--patch-mm 10 5 2.5] [--rays 100 400 1600] [--transient]
    python benchmarks/bench_cavity_radiation.py --view-factors [--scheme air] [--mesh-size 2.0]
    python benchmarks/bench_cavity_radiation.py --thermal-case [--scheme air]

For each law (``effective``, ``s2s``, ``none``) at the default patch size and rays: the
steady rises of tp1 and the three gyros, the steady solve time and its Newton / CG
iterations; for ``s2s`` also the patches, the view-factor time and the reciprocity and
closure residuals before and after their enforcement. ``--patch-mm`` and ``--rays`` add the
convergence of the s2s rises with the patch size and the rays per patch. ``--transient`` runs
the power-on transient with s2s (adaptive TR-BDF2, default and 10x tighter tolerance): tp1's
t63/t95 and the largest site difference between the two, which bounds the error of the lagged
exchange together with the time discretisation.

``--view-factors`` (only this): where the s2s view factors' time goes at the study's patch choice, each part
compiled (:mod:`imutherm.thermal.ray_march`) against its numpy version as before, paired in one run: the rays'
emission, the ray march (the hits compared), the reciprocity/closure balancing (sparse against dense products),
and the whole view factors each way (the kernels' first calls, numba's import and load or compile, apart); then
the exchange matrix the law builds from them (push-through form against the direct radiosity solve).

``--thermal-case`` (only this): the study's thermal case of the scheme (``imutherm compare``'s: steady, reduced
power-on transient and its check, oven self-heating, the mesh-error estimate), each in a fresh process, first
with the view factors and exchange matrix as before (numpy placement and march, dense balancing, direct
radiosity solve), then as now: wall and CPU seconds of each, and the largest difference of the sensor dies'
rises between the two.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import load_layout
from imutherm.geometry.mesh import build_mesh
from imutherm.thermal import cavity_radiation
from imutherm.thermal.cavity_radiation import DEFAULT_PATCH_MM, DEFAULT_RAYS
from imutherm.thermal.metrics import thermal_metrics
from imutherm.unit.model import ModelOptions, build_problem
from imutherm.thermal.solve import solve_steady, solve_transient

SITES = ("tp1", "gyro_x", "gyro_y", "gyro_z")


def steady(geometry, grid, options):
    t0 = time.perf_counter()
    pb = build_problem(geometry, grid, options)
    build_s = time.perf_counter() - t0
    r = solve_steady(pb, probes=dict(geometry.sites))
    rise = dict(zip(r.probe_names, (float(v) - pb.ambient_C for v in r.probe_C)))
    return pb, r, rise, build_s


def line(label, pb, r, rise, build_s):
    s = f"{label:<28s} " + " ".join(f"{n} {rise[n]:6.2f} K" for n in SITES)
    s += f" | build {build_s:5.1f} s, steady {r.solve_s:5.1f} s, Newton {r.iterations}, CG {r.linear_iterations}"
    if pb.exchanges:
        ex = pb.exchanges[0]
        v = ex.view
        s += (f" | {ex.patches.n} patches, {v.rays} rays, view factors {v.seconds:.1f} s, reciprocity "
              f"{v.raw_reciprocity:.2g} -> {v.reciprocity:.1g}, closure {v.raw_closure:.1g} -> {v.closure:.1g}, "
              f"lost rays {v.lost}")
    print(s, flush=True)


_enforce = cavity_radiation._enforce


def _dense_enforce(F, area, tol=1e-13, max_iter=5000):
    """The enforcement's balancing with dense products, as :func:`cavity_radiation._enforce` did before it used
    sparse ones (for the paired time)."""
    S = area[:, None] * F
    S = 0.5 * (S + S.T)
    d = np.ones(len(area))
    ok = S.sum(axis=1) > 0
    rs = S @ d
    for _ in range(max_iter):
        d[ok] = np.sqrt(d[ok] * area[ok] / rs[ok])
        rs = S @ d
        if np.max(np.abs(d[ok] * rs[ok] / area[ok] - 1.0), initial=0.0) < tol:
            break
    return d[:, None] * S * d[None, :] / area[:, None]


def _direct_exchange(F, area, eps):
    """exchange_matrix's X solved for ``M^-1 E`` and multiplied by F, as before its push-through form."""
    n = len(area)
    Minv_E = np.linalg.solve(np.eye(n) - (1.0 - eps)[:, None] * F, np.diag(eps))
    X = area[:, None] * (Minv_E - F @ Minv_E)
    X = 0.5 * (X + X.T)
    X[np.diag_indices(n)] -= X.sum(axis=1)
    return X


def view_factor_times(geometry, grid, options, repeat=3):
    """The view factors' parts on ``grid`` [s], each the least of ``repeat`` runs, and
    the whole with every part compiled against the whole as before (numpy placement and march, dense balancing)."""
    from imutherm.thermal.ray_march import march, march_numpy, place_rays, place_rays_numpy

    air = grid.cell_part == grid.part_names.index("fill")
    pt = cavity_radiation.choose_patch_mm(grid, air, options.cavity_patch_mm, options.cavity_max_patches).patches
    rays = options.cavity_rays
    cr = cavity_radiation

    def best(f, n=repeat):
        out, times = None, []
        for _ in range(n):
            t0 = time.perf_counter()
            out = f()
            times.append(time.perf_counter() - t0)
        return out, min(times)

    def emit():
        return cr._emit(pt, grid, rays, np.random.default_rng(0))

    def whole():
        return cr.view_factors(grid, air, pt, rays, np.random.default_rng(0))
    _, t_first = best(lambda: (emit(), march(grid, air, pt.face_patch, np.zeros((1, 3)), np.ones((1, 3)),
                                             np.zeros((1, 3), np.int64))), 1)
    (pos, dirs, cell, src), t_emit = best(emit)
    (hit, crossed), t_jit = best(lambda: march(grid, air, pt.face_patch, pos, dirs, cell, counts=True))
    ref, t_np = best(lambda: march_numpy(grid, air, pt.face_patch, pos, dirs, cell))
    F = np.zeros((pt.n, pt.n))
    np.add.at(F, (src, hit), 1.0 / rays)
    _, t_enf = best(lambda: cr._enforce(F, pt.area))
    _, t_dense = best(lambda: _dense_enforce(F, pt.area))
    vf, t_vf = best(whole)
    cr.march, cr.place_rays, cr._enforce = march_numpy, place_rays_numpy, _dense_enforce
    try:
        _, t_emit_np = best(emit)
        before, t_before = best(whole)
    finally:
        cr.march, cr.place_rays, cr._enforce = march, place_rays, _enforce
    print(f"{pt.n} patches x {rays} rays = {len(pos):,} rays, {crossed:,} cells crossed "
          f"({crossed / len(pos):.1f} a ray); the kernels' first calls (numba's import and load or compile) "
          f"{t_first:.2f} s")
    print("| part | compiled [s] | numpy, as before [s] | ratio |\n|---|---|---|---|")
    for name, a, b in (("rays' emission", t_emit, t_emit_np), ("ray march", t_jit, t_np),
                       ("reciprocity and closure (sparse / dense products)", t_enf, t_dense),
                       ("view factors, all", t_vf, t_before)):
        print(f"| {name} | {a:.3f} | {b:.3f} | {b / a:.1f} |")
    eps = np.random.default_rng(0).uniform(0.05, 0.95, pt.n)   # the exchange's cost does not depend on the values
    X, t_x = best(lambda: cavity_radiation.exchange_matrix(vf.F, pt.area, eps))
    X0, t_x0 = best(lambda: _direct_exchange(vf.F, pt.area, eps))
    print(f"| exchange matrix X (push-through / direct radiosity solve) | {t_x:.3f} | {t_x0:.3f} | {t_x0 / t_x:.1f} |")
    print(f"the same hits: {np.array_equal(hit, ref)}; F largest difference {np.abs(vf.F - before.F).max():.1g}; "
          f"X relative difference {np.abs(X - X0).max() / np.abs(X0).max():.1g}", flush=True)


def _thermal_case_once(scheme: str, before: bool) -> None:
    """One thermal case in this process; prints a JSON line (wall, CPU [s], the dies' steady rises [K])."""
    import json

    from imutherm.imu.sensor_model import SITES
    from imutherm.studies.end_to_end.thermal import thermal_case
    from imutherm.thermal import ray_march

    if before:
        cr = cavity_radiation
        cr.march, cr.place_rays, cr._enforce = ray_march.march_numpy, ray_march.place_rays_numpy, _dense_enforce
        cr.exchange_matrix = _direct_exchange
    c0, t0 = time.process_time(), time.perf_counter()
    res, _, rise, _ = thermal_case(load_layout(None), scheme, ModelOptions(), (-40.0, 70.0),
                                   transient_model="reduced", estimate_mesh_error=True)
    st = res.steady
    dies = [float(st.probe_C[st.probe_names.index(s)]) for s in SITES]
    print(json.dumps({"wall": time.perf_counter() - t0, "cpu": time.process_time() - c0, "dies": dies,
                      "oven": np.asarray(rise).ravel().tolist()}))


def thermal_case_times(scheme: str) -> None:
    """:func:`_thermal_case_once` as before and as now, each in a fresh process (module docstring)."""
    import json
    import subprocess
    import sys

    runs = {}
    for label in ("before", "now"):
        out = subprocess.run([sys.executable, __file__, "--scheme", scheme, "--_case", label], check=True,
                             capture_output=True, text=True).stdout
        runs[label] = json.loads(out.strip().splitlines()[-1])
    b, n = runs["before"], runs["now"]
    print(f"thermal case of {scheme} (steady, reduced transient and check, oven, mesh-error estimate), each in a "
          f"fresh process: before {b['wall']:.1f} s wall / {b['cpu']:.1f} CPU-s, now {n['wall']:.1f} s / "
          f"{n['cpu']:.1f} CPU-s; CPU ratio {b['cpu'] / n['cpu']:.2f}, CPU saved {b['cpu'] - n['cpu']:.1f} s")
    print(f"largest difference: sensor dies' steady values {np.abs(np.subtract(b['dies'], n['dies'])).max():.1g} K, "
          f"oven rises {np.abs(np.subtract(b['oven'], n['oven'])).max():.1g} K", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scheme", default="air")
    ap.add_argument("--mesh-size", type=float, default=2.0)
    ap.add_argument("--patch-mm", type=float, nargs="*", default=[])
    ap.add_argument("--rays", type=int, nargs="*", default=[])
    ap.add_argument("--transient", action="store_true")
    ap.add_argument("--view-factors", action="store_true", help="only the view factors' times (module docstring)")
    ap.add_argument("--thermal-case", action="store_true", help="only the thermal case as before and now")
    ap.add_argument("--_case", choices=("before", "now"), help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a._case:
        return _thermal_case_once(a.scheme, a._case == "before")
    if a.thermal_case:
        return thermal_case_times(a.scheme)
    lay = load_layout(None)
    geometry = build_geometry(lay, a.scheme)
    grid = build_mesh(geometry, a.mesh_size, 2)
    print(f"reference unit, scheme {a.scheme}, mesh {a.mesh_size} mm: {grid.n_nodes} nodes")
    if a.view_factors:
        view_factor_times(geometry, grid, ModelOptions(cavity_law="s2s"))
        return 0
    for law in ("effective", "s2s", "none"):
        line(law, *steady(geometry, grid, ModelOptions(cavity_law=law)))
    for pm in a.patch_mm:
        line(f"s2s patch {pm:g} mm", *steady(geometry, grid, ModelOptions(cavity_law="s2s", cavity_patch_mm=pm)))
    for n in a.rays:
        line(f"s2s {n} rays/patch", *steady(geometry, grid, ModelOptions(cavity_law="s2s", cavity_rays=n)))
    if a.transient:
        runs = {}
        for law, tol in (("effective", 0.01), ("s2s", 0.01), ("s2s", 0.001)):
            pb = build_problem(geometry, grid, ModelOptions(cavity_law=law))
            st = solve_steady(pb, probes=dict(geometry.sites))
            final = {n: float(v) - pb.ambient_C for n, v in zip(st.probe_names, st.probe_C)}
            t0 = time.perf_counter()
            tr = solve_transient(pb, 3000.0, None, scheme="trbdf2", error_control="probes", tol_K=tol,
                                 probes=dict(geometry.sites))
            m = thermal_metrics(tr, final_rise_K=final)
            runs[(law, tol)] = tr
            i = tr.probe_names.index("tp1")
            print(f"{law} transient tol {tol:g} K: {time.perf_counter() - t0:.1f} s, {tr.steps} steps, "
                  f"tp1 t63 {m.t63_s['tp1']:.0f} s, t95 {m.t95_s['tp1']:.0f} s, "
                  f"tp1(3000 s) {tr.probe_C[-1, i] - pb.ambient_C:.3f} K", flush=True)
        a_, b_ = runs[("s2s", 0.01)], runs[("s2s", 0.001)]
        diff = max(float(np.max(np.abs(np.interp(b_.times, a_.times, a_.probe_C[:, j]) - b_.probe_C[:, j])))
                   for j in range(len(a_.probe_names)))
        print(f"s2s: largest site difference between the two tolerances over the run: {diff:.4f} K")
    print(f"(defaults: patch {DEFAULT_PATCH_MM:g} mm, {DEFAULT_RAYS} rays per patch)")


if __name__ == "__main__":
    import sys

    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    name, title = "cavity_radiation", "the cavity radiation laws"
    if "--view-factors" in sys.argv:
        name, title = "cavity_view_factors", "the s2s view factors' time by part"
    elif "--thermal-case" in sys.argv:
        name, title = "cavity_thermal_case", "a scheme's thermal case, view factors as before and now"
    sys.exit(_record.run(main, name, title))
