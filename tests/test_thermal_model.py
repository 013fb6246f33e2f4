"""The unit's thermal model: cell properties, boundary laws, interfaces and cavity radiation."""

import numpy as np
import pytest

from imutherm import InputError
from imutherm.geometry.build import build_geometry
from imutherm.geometry.grid import TensorGrid
from imutherm.geometry.layout import AXES
from imutherm.geometry.materials import get_material
from imutherm.geometry.mesh import build_mesh
from imutherm.unit.model import (GREASE_WETTED_JOINT_W_M2K, Interface, ModelOptions, _apply_interface, _run_lengths,
                                    build_problem, cavity_radiation_conductivity, unit_interfaces)
from imutherm.thermal.problem import (SIGMA, Contact, FixedTemperature, NaturalConvection, Radiation,
                                      ThermalProblem)
from imutherm.thermal.solve import solve_steady


@pytest.fixture(scope="module")
def unit():
    g = build_geometry(None, "grease")
    m = build_mesh(g, max_cell_mm=4.0, min_cells=1)
    return g, m


def test_cells_carry_their_part_properties(unit):
    g, m = unit
    p = build_problem(g, m, ModelOptions(cavity_radiation=False, interfaces=()))
    flat = m.cell_part.ravel()
    vol = m.cell_volumes().ravel()
    assert np.dot(p.q, vol) == pytest.approx(g.total_power_W, rel=1e-12)
    die = m.part_names.index("processor_die")
    assert np.all(p.q[flat == die] == pytest.approx(0.35 / g.volumes["processor_die"]))
    assert np.all(p.q[flat != die][~np.isin(flat[flat != die], [m.part_names.index(n) for n in m.part_names
                                                               if n.endswith("_die")])] == 0)
    pcb = get_material("pcb_fr4_4layer")
    for board in ("main", "xboard", "yboard"):
        k = p.k[flat == m.part_names.index(board)]
        n = AXES.index(g.part(board).normal)
        assert np.all(k[:, n] == pcb.k_through)  # through-plane along the board normal
        assert np.all(np.delete(k, n, axis=1) == pcb.k_in_plane)
    fill = p.k[flat == m.part_names.index("fill")]
    assert np.all(fill == get_material("air").k_in_plane)
    assert np.all(p.rho_c[flat == m.part_names.index("housing")] == get_material("aluminium_6061_anodised").rho_c)


def test_boundary_laws_follow_the_layout_and_the_switches(unit):
    g, m = unit
    p = build_problem(g, m)
    (mount,) = p.boundary["zmin"]
    assert isinstance(mount, Contact) and mount.conductance == g.layout.mounting.contact_conductance_W_m2K
    for face in ("xmin", "xmax", "ymin", "ymax", "zmax"):
        kinds = [type(law) for law in p.boundary[face]]
        assert kinds == [NaturalConvection, Radiation]
        assert p.boundary[face][1].emissivity == pytest.approx(0.84)
    assert p.boundary["zmax"][0].orientation == "up" and p.boundary["xmin"][0].orientation == "vertical"
    assert p.boundary["xmin"][0].length == pytest.approx(0.025)
    p2 = build_problem(g, m, ModelOptions(exterior="fixed", h_fixed_W_m2K=7.0, radiation=False,
                                          mounting_conductance_W_m2K=0.0))
    assert p2.boundary["zmin"] == ()
    assert [law.h for law in p2.boundary["xmax"]] == [7.0]
    with pytest.raises(InputError, match="emissivity must be in"):
        ModelOptions(emissivity=1.5)
    with pytest.raises(InputError, match="valid: natural, fixed, none"):
        ModelOptions(exterior="wind")


def test_interface_conductance_is_exact_in_series():
    """Two 10 mm blocks (k 2 and 5) with an interface h = 400 W/m^2 K between fixed-temperature ends:
    the flux is dT / (L1/k1 + L2/k2 + 1/h), exact to solver precision on any grid."""
    xs = np.concatenate([np.linspace(0, 0.01, 4), np.linspace(0.01, 0.02, 6)[1:]])
    g = TensorGrid(xs, np.array([0, 0.01]), np.array([0, 0.01]),
                   np.where(np.arange(len(xs) - 1) < 3, 0, 1).reshape(-1, 1, 1).astype(np.int32), ("a", "b"), {})
    k = np.where(g.cell_part.ravel() == 0, 2.0, 5.0)[:, None] * np.ones(3)
    k3 = k.reshape(*g.shape, 3)
    _apply_interface(k3, g, Interface("a", "b", 400.0))
    prob = ThermalProblem(g, k3.reshape(-1, 3), np.ones(g.n_cells), np.zeros(g.n_cells), 0.0,
                          {"xmin": (FixedTemperature(100.0),), "xmax": (FixedTemperature(0.0),)})
    r = solve_steady(prob)
    flux = 100.0 / (0.01 / 2.0 + 0.01 / 5.0 + 1 / 400.0) * 1e-4  # [W] through 1 cm^2
    assert r.heat_out_W["xmax"] == pytest.approx(flux, rel=1e-9)
    with pytest.raises(InputError, match="do not touch"):
        _apply_interface(k3, TensorGrid(xs, g.ys, g.zs, np.zeros_like(g.cell_part), ("a", "b"), {}),
                         Interface("a", "b", 400.0))


def test_cavity_radiation_run_lengths_and_conductivity():
    mask = np.array([True, True, False, True, True, True, False])[:, None, None]
    w = np.array([1.0, 2.0, 5.0, 1.0, 1.0, 1.0, 9.0])
    runs = _run_lengths(mask, w, 0)[:, 0, 0]
    assert runs[mask[:, 0, 0]].tolist() == [3.0, 3.0, 3.0, 3.0, 3.0]
    runs = _run_lengths(np.array([True, False, True])[:, None, None], np.array([2.0, 1.0, 4.0]), 0)[:, 0, 0]
    assert runs.tolist() == [2.0, 0.0, 4.0]
    # parallel plates: h_r = 4 sigma eps T^3
    k = cavity_radiation_conductivity(0.01, 76.85, 0.8)
    assert k == pytest.approx(4 * SIGMA * 0.8 * 350.0**3 * 0.01, rel=1e-12)


def test_cavity_radiation_only_in_air(unit):
    """The effective law raises the air's conductivity only; the s2s law (the default) leaves every
    conductivity alone and adds one exchange; potting is opaque under both."""
    g, m = unit
    on = build_problem(g, m, ModelOptions(cavity_law="effective"))
    off = build_problem(g, m, ModelOptions(cavity_radiation=False))
    fill = m.cell_part.ravel() == m.part_names.index("fill")
    assert np.all(on.k[fill] > off.k[fill]) and np.all(on.k[~fill] == off.k[~fill])
    s2s = build_problem(g, m)
    assert ModelOptions().cavity_law == "s2s"
    assert np.array_equal(s2s.k, off.k) and len(s2s.exchanges) == 1 and not off.exchanges
    gp = build_geometry(None, "potted")
    mp = build_mesh(gp, 4.0, 1)
    for law in ("effective", "s2s"):
        a, b = build_problem(gp, mp, ModelOptions(cavity_law=law)), build_problem(gp, mp, ModelOptions(cavity_radiation=False))
        assert np.array_equal(a.k, b.k) and not a.exchanges  # potting is opaque


def test_lid_joint_lowers_conductivity_of_the_touching_lid_layer(unit):
    g, m = unit
    with_joint = build_problem(g, m, ModelOptions(cavity_radiation=False))
    without = build_problem(g, m, ModelOptions(cavity_radiation=False, interfaces=()))
    lid = m.cell_part == m.part_names.index("lid")
    changed = (with_joint.k != without.k).any(axis=1).reshape(m.shape)
    assert changed.any() and np.all(lid[changed])
    # only the z-conductivity of the bottom lid layer above the housing rim
    assert np.array_equal(with_joint.k[:, :2], without.k[:, :2])


def test_bond_lines_and_standoffs_get_their_contact_conductances(unit):
    g, m = unit
    pairs = {(i.part_a, i.part_b): i.conductance_W_m2K for i in unit_interfaces(g, ModelOptions())}
    for chip in ("processor", "reg_5v", "reg_3v3", "reg_1v8"):   # both faces of every grease bond line
        assert pairs[(chip, chip + "_bond")] == pytest.approx(GREASE_WETTED_JOINT_W_M2K)
        assert pairs[("housing", chip + "_bond")] == pytest.approx(GREASE_WETTED_JOINT_W_M2K)
    for i in range(1, 5):                                        # standoffs: base and main board
        assert ("housing", f"standoff_{i}") in pairs and ("main", f"standoff_{i}") in pairs
    assert len(pairs) == 1 + 8 + 8                                # nothing else touches by accident
    # the processor bond's z-conductivity drops to the exact series value in the layer at each face
    on = build_problem(g, m, ModelOptions(cavity_radiation=False))
    off = build_problem(g, m, ModelOptions(cavity_radiation=False, bond_contact_W_m2K=None))
    bond = (m.cell_part == m.part_names.index("processor_bond")).ravel()
    changed = on.k[bond, 2] != off.k[bond, 2]
    w = np.broadcast_to(m.cell_sizes()[2], m.shape).ravel()[bond]
    series = w / (w / off.k[bond, 2] + 1.0 / GREASE_WETTED_JOINT_W_M2K)
    assert np.allclose(on.k[bond, 2][changed], series[changed], rtol=1e-12)
    footprint = (m.cell_part == m.part_names.index("processor_bond")).any(axis=2).sum()
    assert changed.sum() == 2 * footprint
    assert np.array_equal(on.k[:, :2], off.k[:, :2])              # only across the bond line
    for air_only in ("air", "potted"):
        names = {b for _, b in ((i.part_a, i.part_b) for i in unit_interfaces(build_geometry(None, air_only),
                                                                          ModelOptions()))}
        assert not any(n.endswith("_bond") for n in names)
    with pytest.raises(InputError, match="bond_contact_W_m2K"):
        ModelOptions(bond_contact_W_m2K=0.0)
