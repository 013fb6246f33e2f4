"""Boundary laws and problem validation: values, derivatives, and clear InputErrors."""

import numpy as np
import pytest

from imutherm import InputError
from imutherm.thermal import (SIGMA, Contact, Convection, FixedTemperature, HeatFlux, NaturalConvection, Radiation,
                              ThermalProblem, contact_layer_conductivity, fields_from_parts, natural_convection_C,
                              natural_convection_h, radiation_flux)
from imutherm.thermal.verification import box_grid


def test_natural_convection_coefficients():
    # Holman Table 7-2: h = C (ΔT/L)^(1/4); ΔT/L = 16/0.01 -> (1600)^(1/4) = 6.3246
    f = (16 / 0.01) ** 0.25
    assert natural_convection_h(16.0, 0.01, "vertical") == pytest.approx(1.42 * f)
    assert natural_convection_h(16.0, 0.01, "up") == pytest.approx(1.32 * f)
    assert natural_convection_h(16.0, 0.01, "down") == pytest.approx(0.59 * f)
    # a cooled top face behaves like a heated bottom face
    assert natural_convection_h(-16.0, 0.01, "up") == pytest.approx(0.59 * f)
    assert natural_convection_h(0.0, 0.01, "vertical") == 0.0


def test_natural_convection_slope_is_floored_and_exact_elsewhere():
    law = NaturalConvection("vertical", 0.05)
    q, dq = law.flux_out(np.array([30.0, 20.0]), 20.0)
    h = natural_convection_h(10.0, 0.05, "vertical")
    assert q[0] == pytest.approx(h * 10.0)
    assert dq[0] == pytest.approx(1.25 * h)           # d/dΔT of C ΔT^(5/4) L^(-1/4)
    assert q[1] == 0.0 and dq[1] > 0                   # Newton stays defined at ΔT = 0


def test_radiation_flux_and_derivative():
    q, dq = radiation_flux(np.array([100.0]), 20.0, 0.8)
    T, Ta = 373.15, 293.15
    assert q[0] == pytest.approx(0.8 * SIGMA * (T ** 4 - Ta ** 4))
    assert dq[0] == pytest.approx(4 * 0.8 * SIGMA * T ** 3)


def test_contact_layer_conductivity():
    assert contact_layer_conductivity(2000.0, 1e-4) == pytest.approx(0.2)
    with pytest.raises(InputError, match="thickness"):
        contact_layer_conductivity(2000.0, 0.0)
    with pytest.raises(InputError, match="conductance"):
        contact_layer_conductivity(-1.0, 1e-4)


@pytest.mark.parametrize("make, match", [
    (lambda: Radiation(1.2), r"emissivity must be in \[0, 1\]"),
    (lambda: Radiation(-0.1), r"emissivity must be in \[0, 1\]"),
    (lambda: Convection(-5.0), "h must be >= 0"),
    (lambda: Contact(-5.0), "conductance must be >= 0"),
    (lambda: Convection(float("nan")), "finite"),
    (lambda: NaturalConvection("sideways", 0.05), "orientation must be one of"),
    (lambda: NaturalConvection("up", 0.0), "length must be > 0"),
    (lambda: HeatFlux("a lot"), "must be a number"),
    (lambda: FixedTemperature(20.0, region=((0.01, 0.0), (0.0, 0.01))), "u1 > u0"),
])
def test_bad_law_parameters_raise_input_error(make, match):
    with pytest.raises(InputError, match=match):
        make()


def _grid():
    return box_grid(np.linspace(0, 0.01, 3), np.linspace(0, 0.01, 3), np.linspace(0, 0.01, 3),
                    parts=np.array([0, 0, 0, 0, 1, 1, 1, 1]), names=("board", "chip"))


def test_negative_conductivity_names_the_part():
    g = _grid()
    k = np.ones((g.n_cells, 3))
    k[5, 2] = -0.3
    with pytest.raises(InputError, match=r"conductivity k must be finite and > 0.*part 'chip'"):
        ThermalProblem(g, k, 1e6, 0.0, 20.0, {})


@pytest.mark.parametrize("kwargs, match", [
    (dict(rho_c=0.0), "rho_c must be finite and > 0"),
    (dict(q=np.full(8, np.inf)), "q must be finite"),
    (dict(k=np.ones(5)), r"k \[W/m K\] must have shape"),
    (dict(boundary={"top": Convection(5.0)}), "unknown boundary face 'top'"),
    (dict(boundary={"zmax": "hot"}), "is not a boundary law"),
    (dict(ambient_C=-300.0), "above absolute zero"),
])
def test_bad_problem_raises_input_error(kwargs, match):
    args = dict(grid=_grid(), k=1.0, rho_c=1e6, q=0.0, ambient_C=20.0, boundary={})
    args.update(kwargs)
    with pytest.raises(InputError, match=match):
        ThermalProblem(**args)


def test_problem_broadcasts_and_freezes_fields():
    pr = ThermalProblem(_grid(), (1.0, 2.0, 3.0), 1e6, 0.0, 20.0, {"xmin": Convection(5.0)})
    assert pr.k.shape == (8, 3) and np.all(pr.k[:, 2] == 3.0)
    assert pr.boundary["xmin"] == (Convection(5.0),)       # a single law becomes a tuple
    with pytest.raises(ValueError):
        pr.k[0, 0] = 5.0


def test_fields_from_parts():
    g = _grid()
    k, rc, q = fields_from_parts(g, {"board": (30, 30, 0.4), "chip": 20.0}, {"board": 2e6, "chip": 1.7e6},
                                 {"chip": 0.5})
    assert k.shape == (8, 3) and k[0, 2] == 0.4 and k[7, 0] == 20.0
    assert float(np.dot(q, g.cell_volumes().ravel())) == pytest.approx(0.5)
    with pytest.raises(InputError, match="missing for parts"):
        fields_from_parts(g, {"board": 1.0}, {"board": 1.0, "chip": 1.0})
    with pytest.raises(InputError, match="unknown parts"):
        fields_from_parts(g, {"board": 1.0, "chip": 1.0}, {"board": 1.0, "chip": 1.0}, {"cpu": 1.0})


def test_layout_face_names_are_accepted():
    g = box_grid([0, 0.01], [0, 0.01], [0, 0.01])
    g = type(g)(g.xs, g.ys, g.zs, g.cell_part, g.part_names, {"zmin": "bottom", "zmax": "top"})
    pr = ThermalProblem(g, 1.0, 1.0, 0.0, 20.0, {"bottom": Contact(500.0), "xmax": Convection(5.0)})
    assert set(pr.boundary) == {"zmin", "xmax"}
    with pytest.raises(InputError, match="given twice"):
        ThermalProblem(g, 1.0, 1.0, 0.0, 20.0, {"bottom": Contact(500.0), "zmin": Convection(5.0)})
    with pytest.raises(InputError, match="valid: xmin.*bottom"):
        ThermalProblem(g, 1.0, 1.0, 0.0, 20.0, {"floor": Contact(500.0)})


def test_natural_convection_C_from_air_properties_matches_holman():
    """Holman's simplified coefficients correspond to a film temperature of ~70..100 °C."""
    assert natural_convection_C("vertical", 100.0) == pytest.approx(1.42, rel=0.02)
    assert natural_convection_C("up", 77.0) == pytest.approx(1.32, rel=0.02)
    assert natural_convection_C("vertical", 27.0) > natural_convection_C("vertical", 100.0)
    with pytest.raises(InputError, match="film_C must be within"):
        natural_convection_C("vertical", 500.0)
