"""The mesh-refinement study of the reference unit: steady rises on a mesh and its uniform refinements.

:func:`refinement_study` solves one scheme of a layout on a base mesh and on the same mesh with every interval
split in 2 and in 3 (:func:`imutherm.geometry.mesh.refine_grid`; the refined solves start from the base field,
:func:`imutherm.thermal.refinement.refined_steady`), and gives per site the observed order of convergence and
the extrapolated rise. :func:`case_reference_unit_refinement` is its verification record for ``imutherm verify``:
on the reference unit's air and grease schemes with linear boundary laws (fixed exterior convection, no
radiation: the discretisation's behaviour alone), every sensor site's rise must grow monotonically under
refinement (Q1 conduction is too stiff, so its rises converge from below) and the lowest order observed at the
sensor dies must be at least the order the study's two-grid estimate assumes
(:data:`~imutherm.thermal.refinement.MESH_ERROR_ORDER`), so that estimate errs on the large side.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

#: the study's base mesh: 6 mm cells, 1 cell across the thinnest parts and gaps (the 3x refinement of the default
#: mesh would be ~5e6 nodes); its 2x and 3x refinements bracket the default mesh's resolution
BASE_MESH_MM, BASE_MIN_CELLS = 6.0, 1
LEVELS = (1, 2, 3)


@dataclass(frozen=True)
class RefinementStudy:
    """Rises of one scheme on a base mesh and its refinements.

    scheme : str; levels : tuple of int (refinement factors); nodes : tuple of int
    names : tuple of str (sites, then ``hot spot``); rise_K : (levels, m) [K]
    order : (m,) [-] observed order (NaN where not monotone); extrapolated_K : (m,) [K]
    monotone : (m,) bool, the rise grows from each level to the next; seconds : float [s]
    """

    scheme: str
    levels: tuple
    nodes: tuple
    names: tuple
    rise_K: np.ndarray
    order: np.ndarray
    extrapolated_K: np.ndarray
    monotone: np.ndarray
    seconds: float


def linear_laws():
    """The model options of the study: linear boundary laws, no radiation (exterior convection at the default
    10 W/m^2 K, the fixture's contact as the layout gives it)."""
    from imutherm.unit.model import ModelOptions

    return ModelOptions(exterior="fixed", radiation=False, cavity_radiation=False)


def refinement_study(layout=None, scheme: str = "air", *, options=None, levels=LEVELS,
                     mesh_size_mm: float = BASE_MESH_MM, min_cells: int = BASE_MIN_CELLS) -> RefinementStudy:
    """Solve ``scheme`` on the base mesh and its refinements by ``levels`` (the first 1); observed orders and
    extrapolated rises from the three finest levels (:func:`imutherm.thermal.refinement.observed_order`)."""
    from imutherm.geometry.mesh import prolongation, refine_grid
    from imutherm.studies.thermal.thermal_study import run_scheme
    from imutherm.thermal.refinement import HOT_SPOT, observed_order, refined_steady
    from imutherm.unit.model import build_problem, cavity_exchange_law

    t0 = time.perf_counter()
    options = options or linear_laws()
    res = run_scheme(layout, scheme, options=options, mesh_size_mm=mesh_size_mm, min_cells=min_cells)
    st, amb = res.steady, res.steady.problem.ambient_C
    sites = {n: res.geometry.sites[n] for n in st.probe_names}
    base = np.append(np.asarray(st.probe_C, float), float(np.max(st.T_C)))
    rises, nodes = [base - amb], [res.grid.n_nodes]
    for f in levels[1:]:
        fine = refine_grid(res.grid, f)
        ex = (cavity_exchange_law(res.geometry, res.grid, res.options).refined(fine, f)
              if st.problem.exchanges else None)
        pf = replace(build_problem(res.geometry, fine, res.options, exchange=ex), boundary=st.problem.boundary)
        est = refined_steady(pf, st.problem, st.T_C, prolongation(res.grid, fine), sites, base[:-1], base[-1],
                             ratio=f)
        rises.append(est.fine_C - amb)
        nodes.append(est.fine_nodes)
    r = np.array(rises)
    order = observed_order(r[-3:], levels[-3:])
    a, b = levels[-2:]
    extra = r[-1] + (r[-1] - r[-2]) / ((b / a) ** order - 1.0)
    monotone = np.all(np.diff(r, axis=0) > 0, axis=0)
    return RefinementStudy(scheme, tuple(levels), tuple(nodes), tuple(sites) + (HOT_SPOT,), r, order, extra,
                           monotone, time.perf_counter() - t0)


def case_reference_unit_refinement(schemes=("air", "grease")):
    """Reference unit, air and grease, linear laws: rises on the base mesh refined 1x, 2x, 3x grow monotonically
    at every sensor site, the lowest observed order at the sensor dies is at least the study's assumed one, and the
    study's corrected answer (from 1x and 2x, :func:`~imutherm.thermal.refinement.bracket`) is within its bound of
    the three-grid extrapolation at every die."""
    from imutherm.imu.sensor_model import SITES
    from imutherm.thermal.refinement import MESH_ERROR_ORDER, bracket
    from imutherm.thermal.verification import checked

    t0 = time.perf_counter()
    studies = [refinement_study(None, s) for s in schemes]
    lowest, notes, bad, outside = np.inf, [], [], []
    for st in studies:
        dies = [st.names.index(n) for n in SITES]
        answer, bound = bracket(st.rise_K[0, dies], st.rise_K[1, dies])
        off = np.abs(st.extrapolated_K[dies] - answer)
        outside += [f"{st.scheme}/{st.names[i]}" for i, o, b in zip(dies, off, bound) if not o <= b]
        p = st.order[dies]
        lowest = min(lowest, float(np.nanmin(p)) if np.isfinite(p).any() else -np.inf)
        bad += [f"{st.scheme}/{st.names[i]}" for i in range(len(st.names) - 1) if not st.monotone[i]]
        notes.append(f"{st.scheme}: nodes {', '.join(f'{n:,}' for n in st.nodes)}; sensor-die rises "
                     + "; ".join(f"{st.names[i]} {' -> '.join(f'{v:.3f}' for v in st.rise_K[:, i])} K "
                                 f"(p {st.order[i]:.2f}, extrapolated {st.extrapolated_K[i]:.3f})" for i in dies)
                     + f"; hot spot p {st.order[-1]:.2f}, extrapolated {st.extrapolated_K[-1]:.3f} K; the corrected "
                     f"answer's bound up to {float(np.max(bound)):.3f} K, its distance from the extrapolation up to "
                     f"{float(np.nanmax(off)):.3f} K")
    error = max(0.0, MESH_ERROR_ORDER - lowest) + (1.0 if bad else 0.0) + (1.0 if outside else 0.0)
    return checked("refinement_reference_unit", "lowest observed order at the sensor dies [-]", lowest,
                   MESH_ERROR_ORDER, error, 0.0,
                   f"reference unit, linear laws, base mesh {BASE_MESH_MM:g} mm / {BASE_MIN_CELLS} cell(s) refined "
                   f"{', '.join(f'{f}x' for f in LEVELS)}: " + " | ".join(notes)
                   + f". Every site's rise grows with refinement: {'yes' if not bad else 'no, ' + ', '.join(bad)}; "
                     "the corrected answer within its bound of the extrapolation at every die: "
                   + ("yes" if not outside else "no, " + ", ".join(outside))
                   + f"; pass: monotone, the lowest order >= the study's assumed {MESH_ERROR_ORDER:g} and every answer "
                     "within its bound (the error recorded: the shortfall of the order, plus 1 if a rise is not "
                     "monotone, plus 1 if an answer is outside its bound)", t0)
