"""Would a test fixture of finite heat capacity explain the paper's slow air-scheme settle (~800 s)?

    python benchmarks/bench_fixture_capacity.py [--mesh-size 4] [--schemes air,grease] [--json out.json]

For each scheme: the unit's power-on transient with the fixture held at 70 degC (the model as it is), the
steady heat into the mount Q_m0, and a steady solve with the fixture 1 K warmer (G_b, S_i); then
:func:`rig_heat_capacity.fixture_response` (``benchmarks/rig_heat_capacity.py``) for aluminium plates of three
sizes in still air and in a fan-stirred chamber. Prints tp1's steady rise and t95 for each (the model's
default laws: s2s cavity law).

Fixture parameters (all assumed: the paper does not describe its fixture):
- aluminium plate, rho c = 2700 kg/m^3 x 896 J/kg K (6061, Incropera Table A.1);
- its loss to the chamber: h x free area (both faces and edges minus the unit's 70 x 48 mm footprint),
  h = 6 W/m^2 K in still air (laminar natural convection ~4-5, Holman Table 7-2, plus radiation of bare
  aluminium eps ~0.1) or 20 W/m^2 K in a fan-stirred oven (low-speed forced convection, Incropera Table 1.1
  gives 25-250 for gases; 20 assumed for a gentle chamber fan).
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace

import numpy as np

from imutherm.geometry.build import MM, build_geometry
from imutherm.geometry.layout import load_layout
from imutherm.geometry.mesh import build_mesh
from imutherm.thermal.assembly import assemble
from imutherm.unit.model import ModelOptions, build_problem
from imutherm.thermal.solve import solve_steady, solve_transient
from rig_heat_capacity import fixture_response, t95  # benchmarks/rig_heat_capacity.py, beside this script

RHO_C_AL = 2700.0 * 896.0          # [J/m^3 K]
FOOTPRINT_M2 = 0.070 * 0.048
PLATES_MM = ((100.0, 100.0, 10.0), (200.0, 150.0, 10.0), (300.0, 300.0, 12.0))
H_W_M2K = (("still air", 6.0), ("fan-stirred", 20.0))
#: points on the base, 0.5 mm above its outer face: their mean rise stands for the mount face's (3 mm of Al)
BASE_POINTS_MM = [(x, y, 0.5) for x in (10.0, 35.0, 60.0) for y in (8.0, 24.0, 40.0)]


def plate(lx, ly, t):
    """(C_f [J/K], free area [m^2]) of an aluminium plate lx x ly x t [mm] under the unit."""
    lx, ly, t = lx * MM, ly * MM, t * MM
    area = 2 * lx * ly + 2 * t * (lx + ly) - FOOTPRINT_M2
    return RHO_C_AL * lx * ly * t, area


def scheme_inputs(scheme: str, mesh_mm: float, options: ModelOptions, t_end: float):
    layout = load_layout(None)
    geo = build_geometry(layout, scheme)
    grid = build_mesh(geo, mesh_mm, 1 if mesh_mm > 2.5 else 2)
    probes = dict(geo.sites)
    probes.update({f"base_{i}": tuple(c * MM for c in p) for i, p in enumerate(BASE_POINTS_MM)})
    pb = build_problem(geo, grid, options)
    asm = assemble(pb)
    st0 = solve_steady(pb, probes=probes, assembly=asm)
    warm = replace(layout, mounting=replace(layout.mounting, temperature_C=layout.mounting.temperature_C + 1.0))
    st1 = solve_steady(build_problem(replace(geo, layout=warm), grid, options), probes=probes)
    q0, q1 = float(st0.heat_out_W["zmin"]), float(st1.heat_out_W["zmin"])
    amb = layout.ambient_C
    r0 = dict(zip(st0.probe_names, np.asarray(st0.probe_C) - amb))
    r1 = dict(zip(st1.probe_names, np.asarray(st1.probe_C) - amb))
    tr = solve_transient(pb, t_end, None, probes=probes, assembly=asm, tol_K=0.01, error_control="probes",
                         scheme="trbdf2")
    # past t_end the held-fixture model has settled: its curves are extended flat to 30 000 s, so the
    # fixture's slow mode can be followed to its own t95
    t = np.append(tr.times, tr.times[-1] + np.arange(100.0, 30000.0 - tr.times[-1], 100.0))
    n_ext = t.size - len(tr.times)
    curves = {n: np.append(c, np.full(n_ext, c[-1]))
              for n, c in zip(tr.probe_names, (np.asarray(tr.probe_C) - amb).T)}
    base = np.mean([curves[f"base_{i}"] for i in range(len(BASE_POINTS_MM))], axis=0)
    base0 = np.mean([r0[f"base_{i}"] for i in range(len(BASE_POINTS_MM))])
    sites = [s for s in geo.sites]
    return dict(t=t, u=base / base0, Q_m0=q0, G_b=q0 - q1, S={s: r1[s] - r0[s] for s in sites},
                rise_fixed={s: curves[s] for s in sites}, steady={s: r0[s] for s in sites},
                power_W=geo.total_power_W, unknowns=int(grid.n_nodes))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh-size", type=float, default=4.0)
    ap.add_argument("--schemes", default="air,grease")
    ap.add_argument("--t-end", type=float, default=3000.0)
    ap.add_argument("--site", default="tp1")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    options = ModelOptions()
    out = {"mesh_size_mm": args.mesh_size, "cavity_law": options.cavity_law, "site": args.site, "schemes": {}}
    for scheme in [s.strip() for s in args.schemes.split(",") if s.strip()]:
        start = time.process_time()
        d = scheme_inputs(scheme, args.mesh_size, options, args.t_end)
        site = args.site
        fixed_t95 = t95(d["t"], d["rise_fixed"][site], d["steady"][site])
        print(f"{scheme}: {d['unknowns']} nodes, {d['power_W']:.3f} W, Q_m0 {d['Q_m0']:.3f} W into the mount, "
              f"G_b {d['G_b']:.3f} W/K, S_{site} {d['S'][site]:.3f}; CPU {time.process_time() - start:.0f} s")
        rows = [{"fixture": "held at 70 C (the model)", "C_J_K": None, "G_W_K": None,
                 "rise_K": d["steady"][site], "t95_s": fixed_t95, "theta_K": 0.0}]
        print(f"  {'fixture':<44} {'C_f J/K':>8} {'G_f W/K':>8} {'theta K':>8} {site + ' K':>8} {'t95 s':>7}")
        print(f"  {rows[0]['fixture']:<44} {'-':>8} {'-':>8} {0.0:8.2f} {d['steady'][site]:8.2f} {fixed_t95:7.0f}")
        for dims in PLATES_MM:
            C, A = plate(*dims)
            for where, h in H_W_M2K:
                r = fixture_response(d["t"], d["rise_fixed"], d["u"], d["Q_m0"], d["G_b"], d["S"], C, h * A)
                tt = t95(r.times, r.rise_K[site], r.rise_steady_K[site])
                name = f"Al plate {dims[0]:g}x{dims[1]:g}x{dims[2]:g} mm, {where}"
                rows.append({"fixture": name, "C_J_K": C, "G_W_K": h * A, "rise_K": r.rise_steady_K[site],
                             "t95_s": tt, "theta_K": r.theta_steady_K, "tau_s": r.tau_s,
                             "settled_in_run": bool(r.rise_K[site][-1] >= 0.95 * r.rise_steady_K[site])})
                print(f"  {name:<44} {C:8.0f} {h * A:8.2f} {r.theta_steady_K:8.2f} {r.rise_steady_K[site]:8.2f} "
                      f"{tt:7.0f}" + ("" if rows[-1]["settled_in_run"] else " (> t_end)"))
        out["schemes"][scheme] = {"Q_m0_W": d["Q_m0"], "G_b_W_K": d["G_b"], "S": d["S"], "rows": rows,
                                  "power_W": d["power_W"], "unknowns": d["unknowns"]}
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1, default=float)


if __name__ == "__main__":
    main()
