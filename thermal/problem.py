"""The thermal problem on a :class:`~imutherm.geometry.grid.TensorGrid` and its boundary laws.

The solver knows nothing about layouts: a :class:`ThermalProblem` is a grid,
three cell fields (diagonal conductivity, volumetric heat capacity, volumetric
power) and, per outer face, a tuple of boundary laws.

Boundary laws are small frozen dataclasses; the physics lives in pure functions
of arrays (:func:`natural_convection_h`, :func:`radiation_flux`), in the style
of ``pvlib.temperature``. All temperatures at this interface are in °C; kelvin
is used only inside :func:`radiation_flux`.

Sign convention: a law's ``flux_out`` is the heat flux *leaving* the solid
[W/m^2]; :class:`HeatFlux` ``q`` is the flux *entering* the solid [W/m^2].

Every law may be limited to a rectangle of its face with
``region=((u0, u1), (v0, v1))`` [m] on the face's two other axes in increasing
axis order (``xmin``/``xmax``: (y, z); ``ymin``/``ymax``: (x, z);
``zmin``/``zmax``: (x, y)). A face cell belongs to the region when its centre
lies inside the rectangle, so grid lines should fall on the rectangle's edges
(the geometry puts them there for a mounting foot).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Union

import numpy as np

from imutherm import InputError
from imutherm.constants import STANDARD_GRAVITY, ZERO_C_K  # noqa: F401  (ZERO_C_K re-exported)
from imutherm.geometry.grid import FACE_NAMES, TensorGrid

#: Stefan–Boltzmann constant [W/m^2 K^4] (CODATA 2018, exact in the 2019 SI).
SIGMA = 5.670374419e-8

#: Laminar natural-convection coefficients C in h = C (|ΔT|/L)^(1/4) [W/m^2 K^1.25 m^0.25]
#: for air at atmospheric pressure (Holman, *Heat Transfer*, 10th ed., Table 7-2,
#: "simplified equations for free convection from various surfaces to air at
#: atmospheric pressure", laminar range 1e4 < Gr Pr < 1e9; the same values are
#: tabulated in Incropera/Cengel-type handbooks). ``up`` = horizontal plate,
#: heated surface facing up (or cooled facing down); ``down`` = heated surface
#: facing down (or cooled facing up).
NATURAL_CONVECTION_C = {"vertical": 1.42, "up": 1.32, "down": 0.59}

#: Air at atmospheric pressure (Incropera & DeWitt, Fundamentals of Heat and Mass Transfer,
#: Table A.4): T [K], conductivity k [W/m K], kinematic viscosity nu [m^2/s], diffusivity alpha [m^2/s].
AIR_TABLE = np.array([
    # T,     k,       nu,        alpha
    [250.0, 0.0223, 11.44e-6, 15.9e-6],
    [300.0, 0.0263, 15.89e-6, 22.5e-6],
    [350.0, 0.0300, 20.92e-6, 29.9e-6],
    [400.0, 0.0338, 26.41e-6, 38.3e-6],
    [450.0, 0.0373, 32.39e-6, 47.2e-6],
])
#: Laminar Nusselt correlations Nu = a Ra^(1/4) behind the C values (McAdams / Incropera ch. 9):
#: vertical plate 0.59 (1e4 < Ra < 1e9), hot surface up 0.54 (1e4 < Ra < 1e7), hot surface down 0.27.
NUSSELT_A = {"vertical": 0.59, "up": 0.54, "down": 0.27}
G_ACC = STANDARD_GRAVITY  # [m/s^2]

Number = Union[int, float]


def natural_convection_C(orientation: str, film_C: float) -> float:
    """Coefficient C of h = C (ΔT/L)^(1/4) from air properties at the film temperature.

    C = a k (g β / (ν α))^(1/4), β = 1/T_film, with ``a`` from
    :data:`NUSSELT_A` and air properties interpolated linearly in
    :data:`AIR_TABLE` (250..450 K). For a housing near 70..100 °C use the film
    temperature (T_surface + T_air)/2.

    Parameters
    ----------
    orientation : {'vertical', 'up', 'down'}
        ``'up'``/``'down'``: heated surface facing up/down.
    film_C : float [°C]

    Returns
    -------
    C : float [W/m^2 K^1.25 m^0.25]
    """
    if orientation not in NUSSELT_A:
        raise InputError(f"natural_convection_C: orientation must be one of {sorted(NUSSELT_A)}, got {orientation!r}")
    T = float(film_C) + ZERO_C_K
    if not AIR_TABLE[0, 0] <= T <= AIR_TABLE[-1, 0]:
        raise InputError(f"natural_convection_C: film_C must be within {AIR_TABLE[0, 0] - ZERO_C_K:.0f}.."
                         f"{AIR_TABLE[-1, 0] - ZERO_C_K:.0f} °C (air table), got {film_C}")
    k, nu, alpha = (np.interp(T, AIR_TABLE[:, 0], AIR_TABLE[:, i]) for i in (1, 2, 3))
    return float(NUSSELT_A[orientation] * k * (G_ACC / T / (nu * alpha)) ** 0.25)


def _check_finite(value, name: str, law: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{law}: {name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{law}: {name} must be finite, got {value!r}")
    return v


def _check_region(region, law: str):
    if region is None:
        return None
    try:
        (u0, u1), (v0, v1) = region
        u0, u1, v0, v1 = (float(x) for x in (u0, u1, v0, v1))
    except (TypeError, ValueError):
        raise InputError(f"{law}: region must be ((u0, u1), (v0, v1)) in metres, got {region!r}") from None
    if not (u1 > u0 and v1 > v0):
        raise InputError(f"{law}: region must have u1 > u0 and v1 > v0 [m], got {region!r}")
    return ((u0, u1), (v0, v1))


# --------------------------------------------------------------------------- physics (pure)

def natural_convection_h(delta_T, length, orientation: str, C: float | None = None, n: float = 0.25):
    """Laminar natural-convection coefficient for air, h = C (|ΔT|/L)^n.

    Parameters
    ----------
    delta_T : array_like [K]
        Surface minus air temperature. The sign matters for horizontal faces:
        a heated face looking up (``'up'``, ΔT > 0) behaves like a cooled face
        looking down, and vice versa.
    length : float [m]
        Characteristic length: height for vertical faces, A/P (area over
        perimeter) or the side for horizontal plates, as in the source.
    orientation : {'vertical', 'up', 'down'}
        Outward normal of the face relative to gravity: ``'up'`` for a top
        face, ``'down'`` for a bottom face, ``'vertical'`` for side faces.
    C : float, optional [W/m^2 K^(1+n) m^n]
        Override of the coefficient; default from :data:`NATURAL_CONVECTION_C`
        (Holman, Heat Transfer, Table 7-2; air at atmospheric pressure). They
        match C = a k (gβ/(να))^(1/4) with air properties at a film
        temperature of ~70..100 °C (:func:`natural_convection_C` gives 1.45 /
        1.42 for vertical plates at 77 / 100 °C), the range of the IMU housing;
        at a 27 °C film C is ~7 % higher.
    n : float [-]
        Exponent, 1/4 for laminar flow.

    Returns
    -------
    h : ndarray [W/m^2 K]
    """
    dT = np.asarray(delta_T, dtype=float)
    if orientation not in NATURAL_CONVECTION_C:
        raise InputError(f"natural convection: orientation must be one of "
                         f"{sorted(NATURAL_CONVECTION_C)}, got {orientation!r}")
    if C is None:
        if orientation == "vertical":
            c = np.full_like(dT, NATURAL_CONVECTION_C["vertical"])
        else:
            heated = dT >= 0
            good, bad = NATURAL_CONVECTION_C["up"], NATURAL_CONVECTION_C["down"]
            if orientation == "up":
                c = np.where(heated, good, bad)
            else:
                c = np.where(heated, bad, good)
    else:
        c = np.full_like(dT, float(C))
    return c * (np.abs(dT) / float(length)) ** n


def radiation_flux(T_C, T_amb_C, emissivity):
    """Net radiative flux from a grey surface to large surroundings.

    q = ε σ (T^4 − T_amb^4), temperatures converted to kelvin inside.

    Parameters
    ----------
    T_C : array_like [°C]
        Surface temperature.
    T_amb_C : float [°C]
        Temperature of the surroundings.
    emissivity : float [-]
        Hemispherical emissivity in [0, 1].

    Returns
    -------
    q : ndarray [W/m^2]
        Flux leaving the surface.
    dq_dT : ndarray [W/m^2 K]
        Its derivative 4 ε σ T^3.
    """
    Tk = np.asarray(T_C, dtype=float) + ZERO_C_K
    Ta = float(T_amb_C) + ZERO_C_K
    es = float(emissivity) * SIGMA
    return es * (Tk ** 4 - Ta ** 4), 4.0 * es * Tk ** 3


def contact_layer_conductivity(conductance, thickness):
    """Effective conductivity of a thin layer that stands for a contact resistance.

    A layer of thickness t and conductivity k has conductance k/t per unit
    area, so ``k = conductance * thickness``.

    Parameters
    ----------
    conductance : float or array_like [W/m^2 K]
        Interface (contact) conductance h_c = 1/R''.
    thickness : float or array_like [m]
        Thickness of the layer part that models the interface.

    Returns
    -------
    k : float or ndarray [W/m K]
    """
    c = np.asarray(conductance, dtype=float)
    t = np.asarray(thickness, dtype=float)
    if np.any(~np.isfinite(c)) or np.any(c <= 0):
        raise InputError(f"contact_layer_conductivity: conductance must be > 0 [W/m^2 K], got {conductance!r}")
    if np.any(~np.isfinite(t)) or np.any(t <= 0):
        raise InputError(f"contact_layer_conductivity: thickness must be > 0 [m], got {thickness!r}")
    k = c * t
    return float(k) if k.ndim == 0 else k


# --------------------------------------------------------------------------- laws

@dataclass(frozen=True)
class FixedTemperature:
    """Prescribed temperature (Dirichlet).

    Attributes
    ----------
    T_C : float or callable [°C]
        Temperature, or a function ``T_C(t [s]) -> [°C]`` (transient only).
    region : ((u0, u1), (v0, v1)) or None [m]
        Optional rectangle of the face (see module docstring).
    """

    T_C: Union[Number, Callable[[float], float]]
    region: tuple | None = None

    def __post_init__(self):
        if not callable(self.T_C):
            object.__setattr__(self, "T_C", _check_finite(self.T_C, "T_C [°C]", "FixedTemperature"))
        object.__setattr__(self, "region", _check_region(self.region, "FixedTemperature"))

    def value(self, t: float | None) -> float:
        """Prescribed temperature [°C] at time ``t`` [s] (``None``: steady)."""
        if callable(self.T_C):
            if t is None:
                raise InputError("FixedTemperature: a time-dependent T_C(t) needs solve_transient")
            return float(self.T_C(t))
        return float(self.T_C)


def _linear_post_init(self, coef_name: str):
    name = type(self).__name__
    c = _check_finite(getattr(self, coef_name), f"{coef_name} [W/m^2 K]", name)
    if c < 0:
        raise InputError(f"{name}: {coef_name} must be >= 0 [W/m^2 K], got {getattr(self, coef_name)!r}")
    object.__setattr__(self, coef_name, c)
    if self.T_C is not None:
        object.__setattr__(self, "T_C", _check_finite(self.T_C, "T_C [°C]", name))
    object.__setattr__(self, "region", _check_region(self.region, name))


@dataclass(frozen=True)
class Convection:
    """Linear convection q_out = h (T − T_C).

    Attributes
    ----------
    h : float [W/m^2 K]
        Heat-transfer coefficient, >= 0.
    T_C : float or None [°C]
        Fluid temperature; ``None`` means the problem's ``ambient_C``.
    region : ((u0, u1), (v0, v1)) or None [m]
    """

    h: float
    T_C: float | None = None
    region: tuple | None = None

    def __post_init__(self):
        _linear_post_init(self, "h")

    @property
    def coefficient(self) -> float:
        """Coefficient of the linear law [W/m^2 K]."""
        return self.h


@dataclass(frozen=True)
class Contact:
    """Contact to a fixture held at ``T_C``: q_out = conductance (T − T_C).

    Attributes
    ----------
    conductance : float [W/m^2 K]
        Contact conductance (1 / contact resistance per area), >= 0.
    T_C : float or None [°C]
        Fixture temperature; ``None`` means ``ambient_C``.
    region : ((u0, u1), (v0, v1)) or None [m]
        E.g. the mounting foot.
    """

    conductance: float
    T_C: float | None = None
    region: tuple | None = None

    def __post_init__(self):
        _linear_post_init(self, "conductance")

    @property
    def coefficient(self) -> float:
        """Coefficient of the linear law [W/m^2 K]."""
        return self.conductance


@dataclass(frozen=True)
class HeatFlux:
    """Prescribed heat flux *into* the solid.

    Attributes
    ----------
    q : float [W/m^2]
        Positive heats the solid.
    region : ((u0, u1), (v0, v1)) or None [m]
    """

    q: float
    region: tuple | None = None

    def __post_init__(self):
        object.__setattr__(self, "q", _check_finite(self.q, "q [W/m^2]", "HeatFlux"))
        object.__setattr__(self, "region", _check_region(self.region, "HeatFlux"))


@dataclass(frozen=True)
class NaturalConvection:
    """Laminar natural convection to air, h = C (|ΔT|/L)^(1/4) (nonlinear).

    See :func:`natural_convection_h` for the correlations (Holman, Heat
    Transfer, Table 7-2) and the meaning of ``orientation``.

    Attributes
    ----------
    orientation : {'vertical', 'up', 'down'}
    length : float [m]
        Characteristic length of the face (> 0).
    T_C : float or None [°C]
        Air temperature; ``None`` means ``ambient_C``.
    C : float or None [W/m^2 K^1.25 m^0.25]
        Optional override of the correlation coefficient (see also
        :func:`natural_convection_C` for C from air properties at a film
        temperature, e.g. ``C=natural_convection_C('vertical', 60.0)``).
    region : ((u0, u1), (v0, v1)) or None [m]
    """

    orientation: str
    length: float
    T_C: float | None = None
    C: float | None = None
    region: tuple | None = None

    #: floor |ΔT| [K] used only in the Newton derivative, where dh/dΔT is singular at 0
    dT_floor: float = field(default=0.5, repr=False)

    def __post_init__(self):
        if self.orientation not in NATURAL_CONVECTION_C:
            raise InputError(f"NaturalConvection: orientation must be one of "
                             f"{sorted(NATURAL_CONVECTION_C)}, got {self.orientation!r}")
        L = _check_finite(self.length, "length [m]", "NaturalConvection")
        if L <= 0:
            raise InputError(f"NaturalConvection: length must be > 0 [m], got {self.length!r}")
        object.__setattr__(self, "length", L)
        if self.T_C is not None:
            object.__setattr__(self, "T_C", _check_finite(self.T_C, "T_C [°C]", "NaturalConvection"))
        if self.C is not None:
            C = _check_finite(self.C, "C", "NaturalConvection")
            if C < 0:
                raise InputError(f"NaturalConvection: C must be >= 0, got {self.C!r}")
            object.__setattr__(self, "C", C)
        object.__setattr__(self, "region", _check_region(self.region, "NaturalConvection"))

    def flux_out(self, T_C, T_air_C):
        """Flux leaving the surface [W/m^2] and a Newton slope [W/m^2 K] at ``T_C`` [°C].

        The slope is the exact derivative (1 + n) h, but never below the secant
        h evaluated at |ΔT| = ``dT_floor`` so that Newton is defined at ΔT = 0.
        """
        dT = np.asarray(T_C, dtype=float) - float(T_air_C)
        h = natural_convection_h(dT, self.length, self.orientation, self.C)
        h_floor = natural_convection_h(np.where(dT >= 0, 1.0, -1.0) * self.dT_floor, self.length,
                                       self.orientation, self.C)
        return h * dT, np.maximum(1.25 * h, h_floor)


@dataclass(frozen=True)
class Radiation:
    """Grey-body radiation to large surroundings, q = ε σ (T^4 − T_C^4) (nonlinear).

    Attributes
    ----------
    emissivity : float [-]
        In [0, 1] (anodised aluminium ~0.85, bare ~0.05–0.1).
    T_C : float or None [°C]
        Temperature of the surroundings; ``None`` means ``ambient_C``.
    region : ((u0, u1), (v0, v1)) or None [m]
    """

    emissivity: float
    T_C: float | None = None
    region: tuple | None = None

    def __post_init__(self):
        e = _check_finite(self.emissivity, "emissivity [-]", "Radiation")
        if not 0.0 <= e <= 1.0:
            raise InputError(f"Radiation: emissivity must be in [0, 1], got {self.emissivity!r}")
        object.__setattr__(self, "emissivity", e)
        if self.T_C is not None:
            object.__setattr__(self, "T_C", _check_finite(self.T_C, "T_C [°C]", "Radiation"))
        object.__setattr__(self, "region", _check_region(self.region, "Radiation"))

    def flux_out(self, T_C, T_sur_C):
        """Flux leaving the surface [W/m^2] and its derivative [W/m^2 K] at ``T_C`` [°C]."""
        return radiation_flux(T_C, T_sur_C, self.emissivity)


LINEAR_LAWS = (Convection, Contact)
NONLINEAR_LAWS = (NaturalConvection, Radiation)
ALL_LAWS = (FixedTemperature, Convection, Contact, HeatFlux, NaturalConvection, Radiation)


# --------------------------------------------------------------------------- the problem

def _as_cell_array(a, grid: TensorGrid, name: str, ncomp: int | None):
    arr = np.array(a, dtype=float, copy=True)
    n = grid.n_cells
    if ncomp is None:
        if arr.ndim == 0:
            arr = np.full(n, float(arr))
        arr = arr.reshape(-1) if arr.shape == grid.shape else arr
        if arr.shape != (n,):
            raise InputError(f"ThermalProblem: {name} must have shape ({n},) (one value per cell), "
                             f"got {np.shape(a)}")
    else:
        if arr.ndim == 0:
            arr = np.full((n, ncomp), float(arr))
        elif arr.shape == (ncomp,) and n != ncomp:
            arr = np.tile(arr, (n, 1))
        elif arr.shape in ((n,), grid.shape):
            arr = np.repeat(arr.reshape(-1, 1), ncomp, axis=1)
        elif arr.shape == grid.shape + (ncomp,):
            arr = arr.reshape(-1, ncomp)
        if arr.shape != (n, ncomp):
            raise InputError(f"ThermalProblem: {name} must have shape ({n}, {ncomp}) "
                             f"(kx, ky, kz per cell), got {np.shape(a)}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class ThermalProblem:
    """A heat-conduction problem on a tensor grid.

    Attributes
    ----------
    grid : TensorGrid
        The conforming mesh (cells in C order over (i, j, k)).
    k : ndarray, shape (n_cells, 3) [W/m K]
        Diagonal conductivity (kx, ky, kz) in global axes, > 0. A scalar or an
        (n_cells,) array is broadcast to isotropic, a (3,) vector to all cells.
    rho_c : ndarray, shape (n_cells,) [J/m^3 K]
        Volumetric heat capacity, > 0.
    q : ndarray, shape (n_cells,) [W/m^3]
        Volumetric power (uniform within each cell).
    ambient_C : float [°C]
        Ambient temperature: initial temperature of a transient and default
        ``T_C`` of the boundary laws.
    boundary : dict
        Outer face name (``xmin`` .. ``zmax``, or the layout's name for it in
        ``grid.face_names``, e.g. ``bottom``) -> tuple of laws applied on it
        (laws on one face add up; faces without laws are adiabatic). Stored
        keyed by ``xmin`` .. ``zmax``.
    exchanges : tuple
        Interior exchange laws between surfaces (e.g. the surface-to-surface cavity radiation,
        :class:`~imutherm.thermal.cavity_radiation.CavityExchange`): objects with ``nodes``,
        ``weights`` [m^2] and ``flux_out(T_nodes [°C], T_ref) -> (q [W/m^2], slope [W/m^2 K])``.
    """

    grid: TensorGrid
    k: np.ndarray
    rho_c: np.ndarray
    q: np.ndarray
    ambient_C: float = 20.0
    boundary: dict = field(default_factory=dict)
    exchanges: tuple = ()

    def __post_init__(self):
        g = self.grid
        if not isinstance(g, TensorGrid):
            raise InputError(f"ThermalProblem: grid must be a TensorGrid, got {type(g).__name__}")
        k = _as_cell_array(self.k, g, "k [W/m K]", 3)
        rho_c = _as_cell_array(self.rho_c, g, "rho_c [J/m^3 K]", None)
        q = _as_cell_array(self.q, g, "q [W/m^3]", None)
        parts = np.asarray(g.cell_part).reshape(-1)

        def where(mask):
            c = int(np.flatnonzero(mask)[0])
            p = g.part_names[int(parts[c])] if len(g.part_names) else "?"
            return f"cell {c} (part {p!r})"

        bad = ~np.isfinite(k) | (k <= 0)
        if bad.any():
            c = np.flatnonzero(bad.any(axis=1))
            raise InputError(f"ThermalProblem: conductivity k must be finite and > 0 [W/m K]; "
                             f"{where(bad.any(axis=1))} has k = {k[c[0]].tolist()}")
        bad = ~np.isfinite(rho_c) | (rho_c <= 0)
        if bad.any():
            raise InputError(f"ThermalProblem: rho_c must be finite and > 0 [J/m^3 K]; "
                             f"{where(bad)} has rho_c = {rho_c[bad][0]}")
        if (~np.isfinite(q)).any():
            raise InputError(f"ThermalProblem: q must be finite [W/m^3]; {where(~np.isfinite(q))}")
        amb = _check_finite(self.ambient_C, "ambient_C [°C]", "ThermalProblem")
        if amb <= -ZERO_C_K:
            raise InputError(f"ThermalProblem: ambient_C must be above absolute zero, got {amb}")
        bnd = {}
        alias = {v: k for k, v in dict(g.face_names or {}).items() if k in FACE_NAMES}
        for face, laws in dict(self.boundary).items():
            face = alias.get(face, face) if face not in FACE_NAMES else face
            if face not in FACE_NAMES:
                valid = list(FACE_NAMES) + sorted(alias)
                raise InputError(f"ThermalProblem: unknown boundary face {face!r}; valid: {', '.join(valid)}")
            if face in bnd:
                raise InputError(f"ThermalProblem: face {face!r} is given twice (by its grid and its layout name)")
            if isinstance(laws, ALL_LAWS):
                laws = (laws,)
            laws = tuple(laws)
            for law in laws:
                if not isinstance(law, ALL_LAWS):
                    raise InputError(f"ThermalProblem: face {face!r}: {law!r} is not a boundary law "
                                     f"({', '.join(c.__name__ for c in ALL_LAWS)})")
            bnd[face] = laws
        object.__setattr__(self, "k", k)
        object.__setattr__(self, "rho_c", rho_c)
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "ambient_C", amb)
        object.__setattr__(self, "boundary", bnd)
        exchanges = tuple(self.exchanges)
        for ex in exchanges:
            if not (hasattr(ex, "flux_out") and hasattr(ex, "nodes") and hasattr(ex, "weights")):
                raise InputError(f"ThermalProblem: exchange {ex!r} has no nodes, weights and flux_out")
            if len(ex.nodes) and (np.min(ex.nodes) < 0 or np.max(ex.nodes) >= g.n_nodes):
                raise InputError("ThermalProblem: an exchange law refers to nodes outside the grid")
        object.__setattr__(self, "exchanges", exchanges)

    @property
    def power_W(self) -> float:
        """Total volumetric power [W]."""
        return float(np.dot(self.q, self.grid.cell_volumes().reshape(-1)))

    def law_T_C(self, law) -> float:
        """Reference temperature of a law [°C] (its ``T_C`` or the ambient)."""
        return self.ambient_C if getattr(law, "T_C", None) is None else float(law.T_C)


def fields_from_parts(grid: TensorGrid, k: dict, rho_c: dict, power_W: dict | None = None):
    """Cell fields from per-part properties.

    Parameters
    ----------
    grid : TensorGrid
    k : dict
        Part name -> conductivity [W/m K], a scalar or (kx, ky, kz). Every part
        must be given.
    rho_c : dict
        Part name -> volumetric heat capacity [J/m^3 K].
    power_W : dict, optional
        Part name -> total power [W], spread uniformly over the part's volume.

    Returns
    -------
    k_cells : ndarray (n_cells, 3) [W/m K]
    rho_c_cells : ndarray (n_cells,) [J/m^3 K]
    q_cells : ndarray (n_cells,) [W/m^3]
    """
    names = list(grid.part_names)
    parts = np.asarray(grid.cell_part).reshape(-1)
    vol = grid.cell_volumes().reshape(-1)
    for what, d in (("k", k), ("rho_c", rho_c)):
        missing = [p for p in names if p not in d]
        if missing:
            raise InputError(f"fields_from_parts: {what} missing for parts {missing}")
    for what, d in (("k", k), ("rho_c", rho_c), ("power_W", power_W or {})):
        unknown = [p for p in d if p not in names]
        if unknown:
            raise InputError(f"fields_from_parts: {what} names unknown parts {unknown}; valid: {names}")
    k_tab = np.array([np.broadcast_to(np.asarray(k[p], dtype=float), (3,)) for p in names])
    rc_tab = np.array([float(rho_c[p]) for p in names])
    q_tab = np.zeros(len(names))
    for p, P in (power_W or {}).items():
        i = names.index(p)
        V = vol[parts == i].sum()
        if V <= 0:
            raise InputError(f"fields_from_parts: part {p!r} has no cells but power {P} W")
        q_tab[i] = float(P) / V
    return k_tab[parts], rc_tab[parts], q_tab[parts]
