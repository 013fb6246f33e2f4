"""The grade follows the chip: each sensor site's grade from its part, and the study's grade from the sites.

* ``imutherm import`` writes ``grade = "<key>"`` on every site of a ``--site`` part, chosen from the part's value
  or footprint name by the sensor library (:func:`imutherm.imu.sensor_library.grade_for_part`; an unknown chip
  gets ``generic_mems``, said in one line); ``--grade NAME`` (every site) or ``--grade REF=NAME`` overrides.
* ``imutherm compare`` runs the study with the layout's grade: the gyro sites' chip for the gyros and the
  accelerometer sites' chip for the accelerometers (``GYRO+ACCEL`` when they differ); ``--grade`` overrides;
  a layout whose sites name no grade (the reference unit's) keeps the reference grade ``adis16355``.
"""

from __future__ import annotations

from collections import Counter

from imutherm import InputError
from imutherm.imu.grades import GRADES
from imutherm.imu.sensor_library import GENERIC, GradeChoice, grade_for_part, grade_source
from imutherm.site_table import ACCEL_SITES, GYRO_SITES

#: the grade of a layout whose sites name none (the reference unit, Liu et al.'s ADIS16355-class sensors)
DEFAULT_GRADE = "adis16355"


def check_grade(name: str, what: str = "--grade") -> str:
    """``name`` lower-cased if it is a grade (a GRADES key, or ``GYRO+ACCEL`` of two); else one-line InputError."""
    key = str(name).strip().lower()
    parts = key.split("+")
    if not key or len(parts) > 2 or any(p not in GRADES for p in parts):
        chips = sorted(k for k in GRADES if "chip" in GRADES[k] and k != GENERIC)
        raise InputError(f"{what}: unknown grade {name!r}; valid: adis16355, adis16488, ideal, {GENERIC}, the "
                         f"sensor library's chips ({', '.join(chips)}) or GYRO+ACCEL")
    return key


def parse_grade_options(values) -> dict:
    """``--grade NAME`` / ``--grade REF=NAME`` options (repeatable) -> ``{"*" or REF: grade}``."""
    out = {}
    for text in values or ():
        ref, sep, name = str(text).rpartition("=")
        ref = ref.strip() if sep else "*"
        if sep and not ref:
            raise InputError(f"--grade {text!r}: valid: --grade NAME (every site) or --grade REF=NAME")
        if ref in out:
            raise InputError(f"--grade: {'every site' if ref == '*' else ref} is given twice")
        out[ref] = check_grade(name)
    return out


def site_grades(sites: dict, footprints: dict, overrides: dict) -> tuple[dict, list]:
    """Each ``--site`` part's grade and one line per part saying which and why.

    sites : ref -> kind; footprints : ref -> Footprint (``value``, ``library``); overrides : from
    :func:`parse_grade_options`. Returns (ref -> grade key, lines).
    """
    unknown = sorted(set(overrides) - set(sites) - {"*"})
    if unknown:
        raise InputError(f"--grade {unknown[0]}=...: {unknown[0]} is not a --site part; sites: "
                         f"{', '.join(sites) or 'none'}")
    grades, lines = {}, []
    for ref, kind in sites.items():
        if kind == "probe":
            continue
        fp = footprints.get(ref)
        if ref in overrides or "*" in overrides:
            name = overrides.get(ref, overrides.get("*"))
            choice = GradeChoice(name, None, f"site {ref}={kind}: grade {name} (--grade; {grade_source(name)})")
        else:
            choice = grade_for_part(ref, getattr(fp, "value", ""), getattr(fp, "library", ""), kind)
        grades[ref] = choice.grade
        lines.append(choice.line)
    return grades, lines


def layout_grades(layout) -> dict:
    """site name -> grade of a layout's sensor sites that name one, each checked against the sensor library
    (one-line InputError naming the site: the layout's reader checks only the name's form)."""
    out = {}
    for s in layout.sites:
        if getattr(s, "grade", None):
            try:
                out[s.name] = check_grade(s.grade, "grade")
            except InputError as e:
                raise InputError(f"site {s.name!r}: field 'grade': {str(e)[len('grade: '):]}") from None
    return out


def study_grade(layout, requested: str | None) -> tuple[str, list]:
    """The study's grade and one line per sensor-site group naming its grade and source.

    requested : ``--grade`` (None: the layout's sites' grades, else :data:`DEFAULT_GRADE`).
    """
    by_site = layout_grades(layout)
    if requested is not None:
        name = check_grade(requested)
        return name, [f"sensor grade {name} (--grade): {grade_source(name)}"]
    if not by_site:
        return DEFAULT_GRADE, [f"sensor grade {DEFAULT_GRADE} (the layout's sites name no grade: the reference "
                               f"grade): {grade_source(DEFAULT_GRADE)}"]
    lines, chosen = [], {}
    for group, names in (("gyro", GYRO_SITES), ("accel", ACCEL_SITES)):
        found = Counter(by_site[s] for s in names if s in by_site)
        if not found:
            chosen[group] = None
            continue
        top = found.most_common(1)[0][0]
        chosen[group] = top
        sites = ", ".join(s for s in names if by_site.get(s) == top)
        lines.append(f"{group} sites {sites}: grade {grade_source(top)}")
        if len(found) > 1:
            lines.append(f"{group} sites carry {len(found)} grades ({', '.join(found)}): the study takes {top}, the "
                         f"most common (one {group} grade per unit in the model); --grade chooses another")
    g = chosen["gyro"] or chosen["accel"]
    a = chosen["accel"] or chosen["gyro"]
    return (g if g == a else f"{g}+{a}"), lines


def grades_summary(layout, name: str) -> dict:
    """The study's grade, its source and each site's grade, for ``summary.json`` (the report's first page)."""
    return {"grade": name, "source": grade_source(name), "sites": layout_grades(layout)}


def grade_text(data: dict) -> str:
    """``grade icm42688p (ICM-42688-P ...; 4 figures read in the datasheet ...)`` for the report's first page."""
    g = data.get("sensor_grade")
    if not g:
        return f"grade {data['study']['grade']}"
    return f"grade {g['grade']} ({g['source']})"
