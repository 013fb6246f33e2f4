"""The dimensions a footprint's library name carries [mm], wherever they stand in it.

KiCad's library conventions (KLC F2.x) and IPC-7351 names write a package's sizes into its name:
``L_10.4x10.4_H4.8`` (body 10.4 x 10.4 mm, height 4.8 mm), ``SW_PUSH_6mm_H5mm``, ``LED_D3.0mm`` (a
round body of 3.0 mm diameter), ``CP_Radial_D12.5mm_P5.00mm``, ``Crystal_SMD_3225-4Pin_3.2x2.5mm`` (body
3.2 x 2.5 mm), ``Crystal_C26-LF_D2.1mm_L6.5mm_Horizontal`` (a cylinder lying down), ``5.0x5.0x1.6mm`` (three
sizes: the third the height), ``R_Axial_Power_L20.0mm_W6.4mm`` (lying down: its width);
``LED_Rectangular_W5.0mm_H2.0mm`` names a face, not a height. :func:`name_dims` reads them; a vendor prefix (``InvenSense_QFN-24_3x3mm``) or
a library nickname before ``:`` does not matter. Pitches (``P2.54mm``), pad sizes (``Pad1.05x0.95mm``) and
exposed pads (``EP2.8x2.8mm``) are not bodies and are ignored.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

_NUM = r"[0-9]+(?:[.,][0-9]+)?"
#: an explicit height: ``_H4.8``, ``_H5mm``, ``-H3.5`` (a token of its own, H and a number)
_HEIGHT = re.compile(rf"(?<![A-Za-z0-9.])H(?P<h>{_NUM})(?:mm)?(?![0-9A-Za-z])")
#: a round body's diameter: ``D3.0mm``, ``D12.5mm``, ``_D5`` (not ``DO-41``, not ``D_SOD``)
_DIAMETER = re.compile(rf"(?<![A-Za-z0-9.])D(?P<d>{_NUM})(?:mm)?(?![0-9A-Za-z])")
#: a cylinder's length: ``L6.5mm`` beside a diameter
_LENGTH = re.compile(rf"(?<![A-Za-z0-9.])L(?P<l>{_NUM})(?:mm)?(?![0-9A-Za-z])")
#: two or three sizes ``AxB`` / ``AxBxC`` with an optional ``mm`` (not after Pad / EP / P / a letter)
_SIZES = re.compile(rf"(?<![A-Za-z0-9.])(?P<a>{_NUM})x(?P<b>{_NUM})(?:x(?P<c>{_NUM}))?(?:mm)?(?![0-9A-Za-z.])",
                    re.I)
#: a box body's width: ``W6.4mm`` (an axial power resistor lying down)
_WIDTH = re.compile(rf"(?<![A-Za-z0-9.])W(?P<w>{_NUM})(?:mm)?(?![0-9A-Za-z])")
#: IPC / easyeda style ``L4.0-W4.0`` (length and width of the body)
_LW = re.compile(rf"(?<![A-Za-z0-9.])L(?P<a>{_NUM})-W(?P<b>{_NUM})(?:-H(?P<c>{_NUM}))?", re.I)


#: the longest library nickname and footprint name read [characters]: KiCad's names are under 120; a longer one
#: (a damaged or hostile file) is cut, so matching stays a few microseconds a footprint
MAX_NAME_CHARS = 256


def matched_name(library: str) -> str:
    """``Library:Footprint`` cut to what the matching reads (:data:`MAX_NAME_CHARS` of each part)."""
    nick, sep, name = library.rpartition(":")
    return nick[-MAX_NAME_CHARS:] + sep + name[:MAX_NAME_CHARS]


def _num(text: str) -> float:
    return float(text.replace(",", "."))


@dataclass(frozen=True)
class NameDims:
    """Sizes [mm] read from a footprint name (None where the name does not give them).

    height_mm : an explicit height (``_H4.8``, the third of ``AxBxC``), or the diameter of a cylinder lying
    down (``..._D2.1mm_L6.5mm_Horizontal``) / the length of one standing (``..._Vertical``)
    body_mm : (long, short) in-plane sizes of the body (``AxB``); diameter_mm : a round body's diameter
    """

    height_mm: float | None = None
    body_mm: tuple | None = None
    diameter_mm: float | None = None
    height_how: str = ""


def name_dims(library: str) -> NameDims:
    """The sizes in the footprint name ``library`` (``Library:Footprint`` or a bare name)."""
    name = matched_name(library).rpartition(":")[2]
    height, how = None, ""
    m = _HEIGHT.search(name)
    if m and not re.search(rf"(?<![A-Za-z0-9.])W{_NUM}(mm)?_$", name[:m.start()]):   # W5.0mm_H2.0mm: a face
        height, how = _num(m["h"]), f"the name's H{m['h']}"
    body = None
    for m in list(_LW.finditer(name)) + list(_SIZES.finditer(name)):
        before, after = name[:m.start()], name[m.end():]
        if re.search(r"(Pad|EP|P|Pitch|RM)$", before, re.I) or (re.match(r"(-[0-9]*MP)?[_-]P[0-9]", after)
                                                                         and not m.group(0).lower().endswith("mm")) \
                or any(re.fullmatch(r"0[0-9]{3}", t) or _num(t) > 200 for t in (m["a"], m["b"])):
            continue  # a pad, exposed pad or pitch; pin rows x columns (1x04_P2.54mm); an EIA code (4x0603)
        a, b = _num(m["a"]), _num(m["b"])
        body = (max(a, b), min(a, b))
        if m["c"] and height is None:
            height, how = _num(m["c"]), f"the third size of the name's {m.group(0)}"
        break
    diameter = None
    m = _DIAMETER.search(name)
    if m:
        diameter = _num(m["d"])
        length = _LENGTH.search(name)
        body_d = length is not None or re.search(r"LED_D", name)   # else a D may be a drill (Fuseholder_..._D1.17mm)
        if height is None and body_d and (re.search(r"Horizontal", name, re.I) or
                                          (re.search(r"Axial", name, re.I) and not re.search(r"Vertical", name, re.I))):
            height, how = diameter, f"the name's D{m['d']}: a cylinder lying down stands its diameter"
        elif height is None and length and re.search(r"Vertical", name, re.I):
            height, how = _num(length["l"]), f"the name's L{length['l']}: a cylinder standing up"
    w = _WIDTH.search(name)
    if height is None and w and re.search(r"Axial", name, re.I) and not re.search(r"Vertical", name, re.I):
        height, how = _num(w["w"]), f"the name's W{w['w']}: an axial body lying down stands its width"
    return NameDims(height, body, diameter, how)
