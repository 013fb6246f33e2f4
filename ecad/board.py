"""The neutral board description every ECAD reader returns: outline, stack-up, footprints, vias.

Coordinates are the board's own, in mm, **y up** as seen from the top (KiCad's y-down screen coordinates are
flipped by its reader), with the origin at the lower-left corner of the outline's bounding rectangle, so a
footprint's ``(x, y)`` is directly its layout ``center_mm`` (u, v) on a board of normal z. Angles are degrees,
counter-clockwise seen from the top.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle [mm] in some frame: lower corner and upper corner."""

    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def width(self) -> float:
        return self.x1 - self.x0

    @property
    def height(self) -> float:
        return self.y1 - self.y0

    @property
    def centre(self) -> tuple:
        return (0.5 * (self.x0 + self.x1), 0.5 * (self.y0 + self.y1))

    @property
    def area(self) -> float:
        return self.width * self.height

    @staticmethod
    def around(points) -> "Rect | None":
        """The bounding rectangle of ``points`` ((x, y) pairs), None if there are none."""
        pts = list(points)
        if not pts:
            return None
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        return Rect(min(xs), min(ys), max(xs), max(ys))


@dataclass(frozen=True)
class Pad:
    """A copper pad in its footprint's local frame (y up, unrotated) [mm].

    kind : ``smd``, ``thru_hole``, ``np_thru_hole`` (a bare hole) or ``connect``
    rect : the pad's bounding rectangle in the footprint frame
    drill_mm : float or None [mm], the hole's diameter (the smaller side of an oval hole); None for a pad
        without a hole
    """

    name: str
    kind: str
    rect: Rect
    drill_mm: float | None = None


@dataclass(frozen=True)
class Footprint:
    """One placed footprint.

    Attributes
    ----------
    ref : str, the reference designator (``U3``)
    library : str, the footprint's library name (``Package_DFN_QFN:QFN-48-1EP_7x7mm_P0.5mm``)
    value : str, the part value (``STM32G431CBUx``)
    side : ``top`` or ``bottom``
    x, y : float [mm], the footprint origin on the board (see the module docstring)
    rotation_deg : float [deg], counter-clockwise seen from the top
    fab, courtyard : Rect or None, the body outline (fab layer) and courtyard in the footprint frame [mm]
    pads : tuple of Pad
    fields : dict, the footprint's user fields (``Height_mm``, ``Power_W``, ...), as text
    attributes : tuple of str, the file's attributes (``smd``, ``through_hole``, ``virtual``,
        ``exclude_from_bom``, ``board_only``, ``dnp``, ...)
    height_mm : float or None [mm], the body height the file states (IDF does), or the top of the footprint's
        3D model where that file is on the disk (KiCad, :mod:`imutherm.ecad.models3d`); height_source : str,
        which ("" : the board file's component height)
    off_board : str, why the footprint is not on the board modelled ("" when it is): outside the outline,
        on another board or the frame of a panel (set by :func:`imutherm.ecad.panel.pick_board`)
    """

    ref: str
    library: str
    value: str
    side: str
    x: float
    y: float
    rotation_deg: float
    fab: Rect | None
    courtyard: Rect | None
    pads: tuple
    fields: dict = field(default_factory=dict)
    attributes: tuple = ()
    height_mm: float | None = None
    off_board: str = ""
    height_source: str = ""

    def to_board(self, px: float, py: float) -> tuple:
        """A point of the footprint frame [mm] in board coordinates [mm]."""
        a = math.radians(self.rotation_deg)
        c, s = math.cos(a), math.sin(a)
        return (self.x + px * c - py * s, self.y + px * s + py * c)

    @property
    def copper_pads(self) -> tuple:
        """The pads with copper (not bare holes, not paste-only apertures)."""
        return tuple(p for p in self.pads if p.kind != "np_thru_hole")


@dataclass(frozen=True)
class Via:
    """A via through the board: centre [mm] and drill diameter [mm]."""

    x: float
    y: float
    drill_mm: float


@dataclass(frozen=True)
class BoardDesign:
    """A board as read from an ECAD file.

    Attributes
    ----------
    source : str, the file read
    format : str, what it was (``KiCad 7 (20221018)``, ``IDF 3.0``)
    width_mm, height_mm : float [mm], the outline's bounding rectangle (the origin is its lower-left corner)
    outline : tuple of polylines, each a tuple of (x, y) [mm]: the true outline, for drawings
    thickness_mm : float [mm], the board thickness
    copper_layers : int, the number of copper layers
    copper_um : tuple of float [um], each copper layer's thickness (the stack-up's, or the default)
    stackup_source : str, where the thickness and copper come from
    footprints : tuple of Footprint
    vias : tuple of Via
    notes : tuple of str, what the reader found unusual and how it took it (a stack-up far from the usual,
        a panel, ...), printed by ``imutherm import``
    copper : tuple of :class:`~imutherm.ecad.kicad_copper.CopperLayer`, each copper layer's zones, tracks, vias
        and pads, front first (empty when the format gives none: IDF)
    coverage : tuple of float [-], each copper layer's measured coverage within the outline (empty: not
        measured; set by :func:`imutherm.ecad.kicad_copper.with_coverage`)
    """

    source: str
    format: str
    width_mm: float
    height_mm: float
    outline: tuple
    thickness_mm: float
    copper_layers: int
    copper_um: tuple
    stackup_source: str
    footprints: tuple
    vias: tuple = ()
    notes: tuple = ()
    copper: tuple = ()
    coverage: tuple = ()
