"""Which parts the grease scheme of an imported unit bonds: those that set its hot spot and its sensor temperatures.

``imutherm import`` passes :func:`choose` as ``ImportOptions.grease_rule``; in Python, :func:`import_unit`.

The rule (issue 56): solve the unit's air scheme to its steady state on a coarse mesh, linearise the model there
(:func:`imutherm.thermal.small_signal.tangent_operator`: conduction, the face laws' slopes; the cavity's radiation
by the effective law, :data:`RANK_CAVITY_LAW`) and solve it once per powered part at that part's power. Each
solve is that part's share of the rise everywhere [K]; their sum is the linearised rise. A part is bonded when it supplies at least :data:`SHARE` of the
rise at the hot spot or at a sensor site, whatever its share of the power; the sensors themselves are not moved
(their placement and axes are the design's). The hot spot is the air scheme's hottest node.

Cost: one coarse steady solve and one linear solve per powered part (1-4 CPU-s on a 70-80-footprint board).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

#: least share of a target's (hot spot or sensor site) linearised rise a part must supply to be bonded. Assumed:
#: a fifth of the rise is a lever a designer would pull (the reference unit's grease scheme moves parts that
#: supply 15-45 % of its hot spot and sensor rises each); below it bonding a part changes the target by less
#: than the mesh's error at this coarse size
SHARE = 0.2
#: the coarse mesh of the ranking solve [mm] and its cells through thin parts (the test suite's coarse mesh)
RANK_MESH_MM = 6.0
RANK_MIN_CELLS = 1
#: the cavity law of the ranking solve: the effective one (no n^2 view-factor exchange to build). On drone-fc it
#: chose the same parts as the default s2s law in a quarter of the time (3.9 against 15.5 s at load 8)
RANK_CAVITY_LAW = "effective"


@dataclass(frozen=True)
class Influence:
    """Each powered component's share of the air scheme's steady rise [K] at the hot spot and the sensor sites.

    parts : component names; power_W : their powers [W]; hot_spot : the hottest part (its name) and its
    rise [K]; at_hot_spot : (m,) [K]; at_sites : site -> (m,) [K]; wall_s : [s]
    """

    parts: tuple
    power_W: tuple
    hot_spot: str
    hot_spot_rise_K: float
    at_hot_spot: np.ndarray
    at_sites: dict
    wall_s: float

    def chosen(self, exclude=()) -> list:
        """[(component, reason)] of the parts that supply >= SHARE of the hot spot's or a site's rise."""
        out = {}
        hot_total = float(np.sum(self.at_hot_spot))
        for i, name in enumerate(self.parts):
            if name in exclude:
                continue
            why = []
            if hot_total > 0 and self.at_hot_spot[i] >= SHARE * hot_total:
                c = self.at_hot_spot[i]
                why.append(f"{c / hot_total:.0%} of the hot spot's rise ({c:.2f} K)")
            shares = {s: (v[i] / v.sum(), v[i]) for s, v in self.at_sites.items() if v.sum() > 0}
            if shares:
                site, (f, c) = max(shares.items(), key=lambda kv: kv[1][0])
                if f >= SHARE:
                    why.append(f"{f:.0%} of {site}'s ({c:.2f} K)")
            if why:
                out[name] = why
        return [(n, "; ".join(r)) for n, r in out.items()]


def part_influence(layout, scheme: str = "air", mesh_size_mm: float = RANK_MESH_MM,
                   min_cells: int = RANK_MIN_CELLS) -> Influence | None:
    """The :class:`Influence` of each powered component of ``layout`` (a LayoutSpec) in ``scheme``; None if no
    component dissipates."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.mesh import build_mesh
    from imutherm.thermal.assembly import assemble, volume_load
    from imutherm.thermal.linear import ConvergenceError, amg_preconditioner
    from imutherm.thermal.probes import probe_matrix
    from imutherm.thermal.small_signal import tangent_operator
    from imutherm.thermal.steady import solve_steady
    from imutherm.unit.model import ModelOptions, build_problem

    start = time.perf_counter()
    comps = [c.name for c in layout.components if c.power_W > 0]
    if not comps:
        return None
    geometry = build_geometry(layout, scheme)
    grid = build_mesh(geometry, mesh_size_mm, min_cells)
    problem = build_problem(geometry, grid, ModelOptions(cavity_law=RANK_CAVITY_LAW))
    asm = assemble(problem)
    steady = solve_steady(problem, probes=dict(geometry.sites), assembly=asm, solver="amg")
    T = np.asarray(steady.T_C, float)
    tangent = tangent_operator(asm, T)
    A = tangent.operator()
    M = amg_preconditioner((tangent.S + sp.diags(tangent.exchange_diagonal)).tocsr())
    cells = np.asarray(grid.cell_part).reshape(-1)
    names = list(grid.part_names)
    q = np.asarray(problem.q, float).reshape(-1)
    owner = {p.name: (p.parent or p.name) for p in geometry.parts}
    hot = int(np.argmax(T))
    sites = dict(geometry.sites)
    P = probe_matrix(grid, np.array([sites[s] for s in sites])) if sites else None
    at_hot, at_sites, powers = [], [], []
    for comp in comps:
        own = np.isin(cells, [i for i, n in enumerate(names) if owner.get(n) == comp or n == comp])
        qi = np.where(own, q, 0.0)
        Fi = volume_load(SimpleNamespace(grid=problem.grid, q=qi))
        x, info = spla.gmres(A, Fi, M=M, rtol=1e-6, atol=0.0, restart=50, maxiter=20)
        if info != 0:
            raise ConvergenceError(f"grease-scheme ranking: the linearised solve of {comp} did not converge")
        at_hot.append(float(x[hot]))
        at_sites.append(P @ x if P is not None else np.zeros(0))
        powers.append(next(c.power_W for c in layout.components if c.name == comp))
    hot_part = _part_at(grid, hot)
    by_site = {s: np.array([v[j] for v in at_sites]) for j, s in enumerate(sites)}
    return Influence(tuple(comps), tuple(powers), hot_part, float(T[hot] - problem.ambient_C), np.array(at_hot),
                     by_site, time.perf_counter() - start)


def _part_at(grid, node: int) -> str:
    """The part of a cell touching the node ``node`` (the hottest such cell's part is the die around it)."""
    nx, ny, nz = (len(a) for a in (grid.xs, grid.ys, grid.zs))
    i, j, k = np.unravel_index(node, (nx, ny, nz))
    cp = np.asarray(grid.cell_part)
    i, j, k = (min(max(v, 0), s - 1) for v, s in zip((i, j, k), cp.shape))
    return grid.part_names[int(cp[i, j, k])]


def choose(spec, names: dict, sites: dict) -> tuple[dict, list]:
    """({board ref: reason}, notes) of the parts the grease scheme of the imported ``spec`` (no grease scheme yet)
    bonds by the module's rule; ``names`` ref -> component name, ``sites`` the ``--site`` refs (not moved)."""
    inf = part_influence(spec)
    if inf is None:
        return {}, []
    ref_of = {v: k for k, v in names.items()}
    site_names = {names[r] for r in sites if r in names}
    picked = {ref_of[n]: why for n, why in inf.chosen(exclude=site_names) if n in ref_of}
    hot = inf.hot_spot.removesuffix("_die")
    note = (f"grease scheme: the parts chosen by their share of the air scheme's steady rise at the hot spot "
            f"({hot}, +{inf.hot_spot_rise_K:.1f} K on a {RANK_MESH_MM:g} mm mesh) and at the sensor sites, each >= "
            f"{SHARE:.0%} of it, whatever their share of the power ({inf.wall_s:.1f} s): "
            + ("; ".join(f"{r} ({why})" for r, why in picked.items()) if picked else "none")
            + "; --grease REF,... chooses others")
    return picked, [note]


def import_unit(board, opts):
    """:func:`imutherm.ecad.to_layout.import_board` with the grease scheme chosen by :func:`choose` (as ``imutherm
    import`` does); ``opts.grease`` given still wins."""
    from dataclasses import replace

    from imutherm.ecad.to_layout import import_board

    return import_board(board, replace(opts, grease_rule=choose))
