"""A body height [mm] for every footprint, with its source: found, read from the name, or estimated.

The order (the first that gives a height wins):

1. the user's ``--height REF=MM`` / ``--heights FILE``;
2. the footprint's ``Height_mm`` (or ``Height``) field;
3. the height the board file states (IDF; a KiCad part's 3D model when it is read);
4. a height the footprint name states itself: ``_H4.8``, a third size ``5.0x5.0x1.6mm``, a cylinder lying
   down (``D2.1mm ... Horizontal``) (:mod:`imutherm.ecad.name_dims`);
5. the package class of the name (:mod:`imutherm.ecad.packages`: JEDEC outlines, KiCad's library families,
   the footprint generator's size definitions, datasheets), matched anywhere in the name;
6. else an **estimate** by :data:`ESTIMATE` (below): the body's shorter in-plane side times a factor of the
   part's kind, within bounds, chosen so that the packages each kind's reason lists lie at or below it (an
   estimate errs tall; a connector of no known family may stand taller: a pin header does). Estimated heights are listed by ``imutherm import``, carried as
   ``height_source = "estimated: ..."`` in the layout and on the report's parameters page;
   ``--strict-heights`` refuses them instead and ``--heights-template FILE`` writes them out to fill in.
"""

from __future__ import annotations

import csv
import io
import math
import re

from imutherm import InputError
from imutherm.ecad.board import Footprint, Rect
from imutherm.ecad.name_dims import name_dims
from imutherm.ecad.packages import PackageClass

#: the estimate by kind: (factor on the body's shorter side, least [mm], most [mm], why)
ESTIMATE = {
    "passive": (1.0, 0.35, 5.0, "a chip part is at most as thick as it is wide (MLCC 0603 0.8 / 0.8 mm, 1206 "
                                "1.6 / 1.6 mm, tantalum 7343-43 4.3 / 4.3 mm)"),
    "discrete": (1.0, 1.2, 3.0, "a discrete package stands at most its width, and at most 1.2 mm when small "
                                "(SOT-23 1.12 / 1.3 mm, SOD-123 1.35 / 1.6 mm, SMA 2.44 / 2.6 mm, DPAK 2.39 / 6.1 mm)"),
    "ic": (0.5, 1.5, 3.5, "a plastic package or module stands at most half its shorter side, and at most 1.5 mm "
                          "when small (SOIC 1.75 / 3.9 mm, QFN 1.0 / 3 mm, SOT-23-5 1.45 / 1.6 mm, TQFP 1.2 / 10 mm, "
                          "shielded modules 2-3.3 mm)"),
    "inductor": (1.0, 0.5, 10.0, "a power inductor stands at most its side (XAL4020 2.0 / 4 mm, SRN6045 4.5 / 6 mm, "
                                 "XAL1010 10 / 10 mm, chip 1008 2.0 / 2.0 mm)"),
    "connector": (1.0, 1.0, 12.0, "a board connector stands about its shorter side (JST SH 4.25 / 4.25 mm, "
                                  "micro-USB 2.5 / 5 mm, USB-C 3.3 / 7.4 mm); a pin header stands more (8.5 mm on a "
                                  "2.54 mm row: its own class)"),
    "electromechanical": (1.0, 1.0, 12.0, "a switch, crystal or buzzer stands at most its shorter side (6 mm "
                                          "tactile switch 5 / 6 mm, 12 mm buzzer 9.5 / 12 mm, 3225 crystal 0.9 / "
                                          "2.5 mm)"),
}
#: the kind of a part of no package class, by its reference designator's letters
_KIND_BY_REF = (
    (re.compile(r"(U|IC|VR|MOD|M)\d", re.I), "ic"),
    (re.compile(r"(Q|D|LED|TVS|ZD)\d", re.I), "discrete"),
    (re.compile(r"(R|RN|RA|C|CP|FB|F|FUSE|TH|RT|NTC)\d", re.I), "passive"),
    (re.compile(r"L\d", re.I), "inductor"),
    (re.compile(r"(J|P|CN|CON|X|USB|JP|H)\d", re.I), "connector"),
    (re.compile(r"(SW|S|BT|BAT|BZ|LS|Y|XTAL|K|RLY|ANT|E|RV|POT|TR|T)\d", re.I), "electromechanical"),
)
#: the tallest height [mm] a name or table may give (as --height's bound: no taller part fits a small housing)
MAX_HEIGHT_MM = 100.0
#: prefix of every estimated height's source (tests and reports find estimated parts by it)
ESTIMATED = "estimated: "


def is_estimated(source: str) -> bool:
    """True if the height source ``source`` is an estimate (not found or given)."""
    return source.startswith(ESTIMATED)


def kind_of(fp: Footprint, package: PackageClass | None) -> str:
    """The part's kind (:data:`imutherm.ecad.packages.KINDS`): its class's, else by its reference."""
    if package is not None:
        return package.kind
    ref = fp.ref.lstrip("#")
    for pattern, kind in _KIND_BY_REF:
        if pattern.match(ref):
            return kind
    return "ic"


def estimate_height(fp: Footprint, package: PackageClass | None, body: Rect) -> tuple:
    """(height [mm], source) by :data:`ESTIMATE` from the body's shorter side [mm] and the part's kind."""
    kind = kind_of(fp, package)
    factor, lo, hi, why = ESTIMATE[kind]
    short = max(min(body.width, body.height), 0.0)
    h = round(min(max(factor * short, lo), hi), 2)
    return h, (f"{ESTIMATED}{factor:g} x the body's shorter side {short:.2f} mm for a part of kind {kind}, "
               f"within {lo:g}..{hi:g} "
               f"mm ({why}); give Height_mm or --height to replace it")


def field_height(fp: Footprint) -> float | None:
    """The footprint's ``Height_mm`` / ``Height`` field [mm] (None if absent or empty); InputError if not a
    number in 0..100 mm."""
    field = next((v for k, v in fp.fields.items() if k.lower() in ("height_mm", "height") and str(v).strip()), None)
    if field is None:  # an empty field is no height given
        return None
    try:
        value = float(str(field).lower().replace("mm", "").strip())
    except ValueError:
        raise InputError(f"footprint {fp.ref}: field Height_mm {field!r} is not a number [mm]") from None
    if not (math.isfinite(value) and 0 < value <= 100):
        raise InputError(f"footprint {fp.ref}: field Height_mm {value:g} mm is outside 0..100 mm")
    return value


def resolve_height(fp: Footprint, package: PackageClass | None, heights: dict, body: Rect) -> tuple:
    """(height [mm], source) of ``fp`` by the order of the module docstring; never None.

    heights : ref -> (height [mm], source) from the user; body : the body [mm] (for a class sized by it and
    the estimate)."""
    if fp.ref in heights:
        return user_height(fp.ref, heights)
    value = field_height(fp)
    if value is not None:
        return value, "the footprint's Height_mm field"
    if fp.height_mm is not None:   # IDF's, or the top of the footprint's 3D model on the disk (models3d.py)
        return fp.height_mm, fp.height_source or "the board file's component height"
    dims = name_dims(fp.library)
    if dims.height_mm is not None and 0 < dims.height_mm <= MAX_HEIGHT_MM:
        return dims.height_mm, f"the footprint name: {dims.height_how}"
    if package is not None:
        h = package.height(fp.library, max(body.width, body.height))
        if h is not None and 0 < h <= MAX_HEIGHT_MM:   # a name stating 99999 mm states nothing
            if package.height_from_name:   # a size the name states, read by the class (CP_Elec_5x5.4, SSHH codes)
                return h, f"the footprint name, read as {package.name}: {package.source}"
            return h, f"{package.name}: {package.source}"
    return estimate_height(fp, package, body)


def user_height(ref: str, heights: dict) -> tuple:
    """The user's (height [mm], source) of ``ref``; a ``--heights`` line whose source begins with
    ``estimated`` (a :func:`template_csv` line passed back unedited) stays an estimate."""
    h, source = heights[ref]
    if re.search(r"line \d+: estimated", source) and not is_estimated(source):
        return h, f"{ESTIMATED}{source}"
    return h, source


def estimated_parts(decisions) -> list:
    """The decisions of the parts on the board (modelled or merged) whose height is an estimate, by reference."""
    key = lambda d: [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", d.footprint.ref)]  # noqa: E731
    return sorted((d for d in decisions if d.fate in ("modelled", "merged") and is_estimated(d.height_source)), key=key)


def strict_refusal(source: str, parts: list) -> InputError:
    """The one-line refusal of ``--strict-heights``, naming every part without a found height."""
    listed = "; ".join(f"{d.footprint.ref} ({d.footprint.library}, value {d.footprint.value or '?'})" for d in parts)
    return InputError(f"{source}: --strict-heights: no height found for {len(parts)} part"
                      f"{'s' if len(parts) > 1 else ''}: {listed}: add a Height_mm field to each footprint in KiCad, "
                      f"or give --height REF=MM, or --heights FILE (--heights-template FILE writes them all)")


def template_csv(parts: list) -> str:
    """A ``--heights`` file of ``parts``: each with its estimated height, its footprint and the rule in the
    comment above it; a line passed back as it is stays an estimate (:func:`user_height`)."""
    from imutherm.textio import quote

    lines = ["# Heights [mm] the import estimated: replace each height with the part's datasheet height and its",
             "# source with the datasheet's name, then import again with --heights THIS_FILE. A line whose source",
             "# still begins with 'estimated' stays an estimate.",
             "reference,height_mm,source"]
    for d in parts:
        fp = d.footprint
        rule = d.height_source[len(ESTIMATED):] if is_estimated(d.height_source) else d.height_source
        lines.append(f"# {fp.ref}: {quote(fp.library, 120)}, value {quote(fp.value or '?', 60)}, {d.fate}; {rule}")
        row = io.StringIO()
        csv.writer(row, lineterminator="").writerow([fp.ref, f"{d.height_mm:g}",
                                                     "estimated (replace with the datasheet height)"])
        lines.append(row.getvalue())
    return "\n".join(lines) + "\n"
