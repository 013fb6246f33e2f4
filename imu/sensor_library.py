"""Sensor library: grades of common MEMS IMUs from their datasheets, and the grade of a board's chip.

The figures live in ``imu/sensor_library.toml`` (datasheet units, each with its source: ``DS <table>`` read in the
datasheet's own text, or ``recalled, not checked``). :func:`library_grades` turns each chip into a grade dict of
the same structure as :data:`imutherm.imu.grades.GRADES` (merged into it there), so
:func:`imutherm.imu.sensor_model.load_grade` and the whole study take a chip name like any grade.

Conversion rule (datasheet figure -> grade field), the same for every chip:

* **Temperature curves.** The model's bias and scale-factor curves are zero at 25 degC and reach their amplitude
  at the far end of -40..70 degC, 65 K away (:data:`SWING_K`). A tempco ``c`` [per degC] gives the amplitude
  ``c x 65 K``; a change ``d`` over a range ``[lo, hi]`` is read as the tempco ``d / max(|lo-25|, |hi-25|)``
  (linear in the distance from 25 degC; e.g. MPU-6050 ZRO +-20 deg/s over -40..85 degC -> 20 deg/s).
  Datasheet typicals are taken as the 1-sigma part (Bosch's reading); the unit draw scales by 0.5..1.5.
* **White noise.** A one-sided noise density ``ND`` [unit/rtHz] is the Allan random walk ``ND / sqrt(2)``
  [unit/rts] (ADI's ARW = ND x 60 / sqrt(2)); an ARW [deg/rth] / VRW [m/s/rth] is divided by 60. The grade
  stores it as the rms at :data:`RATE_HZ` (``ARW x sqrt(100)``), which the model turns back into the density.
* **Bias instability** [deg/h, ug] is the Allan floor the model's Gauss-Markov process reproduces.
* **Initial tolerances** (ZRO / zero-g at 25 degC, sensitivity tolerance) are the 1-sigma unit-to-unit bias and
  scale factor at 25 degC; **cross-axis sensitivity** ``p`` [%] is the 1-sigma misalignment ``p/100`` rad per
  element; **linear-acceleration sensitivity** is the gyro g-sensitivity.
* **Range** is the full scale (the fusion peer's gyro range); the LSB is that of a 16-bit register at it.
  **ODR**: the study's rate (:data:`RATE_HZ`) must not exceed it. **Temperature-sensor LSB** is the reported
  temperature's quantisation.
* **Not on the datasheet** (assumed, named in the grade's sources): a figure a chip does not give is the median
  of the chips of its class (consumer / industrial / compensated) that give it, else of the consumer chips;
  ``same_as`` takes another chip's figures (same die). Terms no MEMS datasheet gives are scaled from the
  reference grade ``adis16355`` (the paper's model) by the chip's own figures: power-on bias and dT/dt
  coefficients as fractions of the bias curve, rate random walk from the bias instability, the roll coupling
  from the bias curve; the accelerometer asymmetry and K2, the curve's power-on change, the thermal
  misalignment, correlation time and temperature-sensor lag and offset are the reference grade's. Where no chip
  gives a bias instability, it is the reference grade's ratio of bias instability to noise density times the
  chip's density.

The generic consumer-MEMS grade ``generic_mems`` (an unknown chip's) is the median of the consumer chips'
datasheet figures (given ones only), converted by the same rule.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from statistics import median

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

from imutherm import InputError

T_REF_C = 25.0  # [degC] the model curves' zero
SWING_K = 65.0  # [K] farthest temperature from 25 degC in the model's -40..70 degC range
RATE_HZ = 100.0  # [Hz] the study's output rate (the grades' sample_rate_hz)
GENERIC = "generic_mems"
_G0 = 9.80665  # [m/s^2]
_SENSORS = ("gyro", "accel")
#: canonical figures per sensor after normalisation (datasheet units; tempcos per degC)
_GYRO_KEYS = ("range_dps", "nd", "bias_tc", "sf_tc", "bi", "initial_bias_dps", "initial_sf_pct", "cross_axis_pct",
              "g_sensitivity_dps_per_g", "odr_max_hz")
_ACCEL_KEYS = ("range_g", "nd", "bias_tc", "sf_tc", "bi", "initial_bias_mg", "initial_sf_pct", "cross_axis_pct",
               "odr_max_hz")


@lru_cache(maxsize=1)
def library() -> dict:
    """The raw library table (``chips`` -> key -> entry), as read from ``sensor_library.toml``."""
    text = resources.files("imutherm.imu").joinpath("sensor_library.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)["chips"]


def status(src: str) -> str:
    """``checked`` (read in the datasheet: ``DS ...``), ``recalled`` or ``assumed`` for a figure's source."""
    return "checked" if src.startswith("DS ") else "recalled" if src.startswith("recalled") else "assumed"


def _ext(rng) -> float:
    lo, hi = (float(v) for v in rng)
    if not hi > lo:
        raise InputError(f"sensor library: range_C {rng!r} is invalid; valid: [lo, hi] with lo < hi")
    return max(abs(lo - T_REF_C), abs(hi - T_REF_C))


def _canonical(kind: str, raw: dict) -> dict:
    """Normalise one sensor's datasheet figures to the canonical keys -> (value, src)."""
    out = {}
    unit = "dps" if kind == "gyro" else "mg"
    for key, f in raw.items():
        v, src = float(f["v"]), str(f["src"])
        if not (math.isfinite(v) and v >= 0):
            raise InputError(f"sensor library: {kind}.{key} = {v!r} is invalid; valid: a finite value >= 0")
        if key in ("noise_density_dps_rthz", "noise_density_ug_rthz"):
            out["nd"] = (v, src)
        elif key == "arw_deg_rth":
            out["nd"] = (v / 60.0 * math.sqrt(2.0), src + " [ARW -> one-sided density: x sqrt(2)/60]")
        elif key == "vrw_m_s_rth":
            out["nd"] = (v / 60.0 / _G0 * 1e6 * math.sqrt(2.0), src + " [VRW -> one-sided density]")
        elif key == f"bias_tempco_{unit}_per_C":
            out["bias_tc"] = (v, src)
        elif key == f"bias_change_{unit}":
            out["bias_tc"] = (v / _ext(f["range_C"]), src + f" [/ {_ext(f['range_C']):g} K]")
        elif key == "sf_tempco_pct_per_C":
            out["sf_tc"] = (v, src)
        elif key == "sf_change_pct":
            out["sf_tc"] = (v / _ext(f["range_C"]), src + f" [/ {_ext(f['range_C']):g} K]")
        elif key in ("bias_instability_deg_h", "bias_instability_ug"):
            out["bi"] = (v, src)
        elif key in (_GYRO_KEYS if kind == "gyro" else _ACCEL_KEYS):
            out[key] = (v, src)
        else:
            raise InputError(f"sensor library: unknown {kind} figure {key!r}")
    return out


@lru_cache(maxsize=1)
def _given() -> dict:
    """key -> {"gyro": canonical, "accel": canonical, "chip": {temp_lsb_C}} of the figures each chip gives."""
    out = {}
    for key, c in library().items():
        d = {s: _canonical(s, c.get(s, {})) for s in _SENSORS}
        d["chip"] = {"temp_lsb_C": (float(c["temp_lsb_C"]["v"]), c["temp_lsb_C"]["src"])} if "temp_lsb_C" in c else {}
        out[key] = d
    return out


def _class_median(part: str, fig: str, cls: str):
    """Median of ``part``'s figure ``fig`` over the chips of class ``cls`` giving it (None: none does)."""
    vals = [g[part][fig][0] for k, g in _given().items()
            if library()[k]["class"] == cls and fig in g[part] and "same_as" not in library()[k]]
    return (median(vals), len(vals)) if vals else None


def _fill(key: str) -> dict:
    """The chip's canonical figures with every missing one filled by the class rule (src says 'assumed: ...')."""
    c = library()[key]
    if "same_as" in c:
        other = _fill(c["same_as"])
        name = library()[c["same_as"]]["name"]
        return {p: {f: (v, s if s.startswith("assumed") else f"assumed: same die as the {name} ({s})")
                    for f, (v, s) in figs.items()} for p, figs in other.items()}
    cls = c["class"]
    given = _given()[key]
    out = {}
    for part, keys in (("gyro", _GYRO_KEYS), ("accel", _ACCEL_KEYS), ("chip", ("temp_lsb_C",))):
        figs = dict(given[part])
        borrowed = part == "gyro" and not given["gyro"]  # an accelerometer-only part
        for fig in keys:
            if fig in figs:
                continue
            if fig == "bi":
                continue  # below, after the density is known
            for where in (("consumer",) if borrowed or cls == "consumer" else (cls, "consumer")):
                m = _class_median(part, fig, where)
                if m is not None:
                    what = "no gyroscope in the part: generic consumer MEMS" if borrowed else \
                        f"median of the {m[1]} {where} chips giving it"
                    figs[fig] = (m[0], f"assumed: {what}")
                    break
            else:
                if fig in ("g_sensitivity_dps_per_g",):
                    figs[fig] = (None, "assumed: the reference grade's")
        if part != "chip" and "bi" not in figs:
            m = None
            for where in ((cls, "consumer") if cls != "consumer" else ("consumer",)):
                m = _class_median(part, "bi", where)
                if m is not None:
                    figs["bi"] = (m[0], f"assumed: median of the {m[1]} {where} chips giving it")
                    break
            if m is None:
                figs["bi"] = (None, "assumed: the reference grade's ratio of bias instability to noise density")
        out[part] = figs
    return out


def _grade(key: str, name: str, description: str, sources: list, figs: dict, ref: dict) -> dict:
    """Convert canonical figures (datasheet units) to a grade dict of :data:`imutherm.imu.grades.GRADES`."""
    rg, ra = ref["gyro"], ref["accel"]
    gy, ac = {k: v[0] for k, v in figs["gyro"].items()}, {k: v[0] for k, v in figs["accel"].items()}
    for part, d in (("gyro", gy), ("accel", ac)):
        if d["odr_max_hz"] < RATE_HZ:
            raise InputError(f"sensor library: {name} {part} output data rate {d['odr_max_hz']:g} Hz is below the "
                             f"study's {RATE_HZ:g} Hz")
    # white noise: one-sided density -> Allan random walk (/sqrt 2) -> rms at RATE_HZ
    g_arw = gy["nd"] / math.sqrt(2.0)  # [dps/rtHz] -> [deg/s/rts]
    a_arw = ac["nd"] * 1e-3 / math.sqrt(2.0)  # [ug/rtHz] -> [mg/rts]
    ref_g_arw = rg["noise_rms_dps"] / math.sqrt(rg["noise_ref_rate_hz"])
    ref_a_arw = ra["noise_rms_mg"] / math.sqrt(ra["noise_ref_rate_hz"])
    g_bi = gy["bi"] / 3600.0 if gy["bi"] is not None else rg["bias_instability_dps"] / ref_g_arw * g_arw
    a_bi = ac["bi"] * 1e-3 if ac["bi"] is not None else ra["bias_instability_mg"] / ref_a_arw * a_arw
    g_amp = gy["bias_tc"] * SWING_K
    a_amp = ac["bias_tc"] * SWING_K
    g_sens = gy.get("g_sensitivity_dps_per_g")
    gyro = {
        "noise_rms_dps": g_arw * math.sqrt(RATE_HZ), "noise_ref_rate_hz": RATE_HZ,
        "bias_instability_dps": g_bi, "bias_corr_time_s": rg["bias_corr_time_s"],
        "rate_random_walk_dps_per_rts": rg["rate_random_walk_dps_per_rts"] / rg["bias_instability_dps"] * g_bi,
        "lsb_dps": gy["range_dps"] / 32768.0,
        "initial_bias_dps": gy["initial_bias_dps"], "initial_sf_ppm": gy["initial_sf_pct"] * 1e4,
        "misalignment_deg": math.degrees(gy["cross_axis_pct"] / 100.0),
        "misalignment_tempco_deg_per_K": rg["misalignment_tempco_deg_per_K"],
        "turn_on_bias_dps": rg["turn_on_bias_dps"] / rg["bias_temp_amplitude_dps"] * g_amp,
        "bias_temp_amplitude_dps": g_amp, "sf_temp_amplitude_ppm": gy["sf_tc"] * 1e4 * SWING_K,
        "power_on_curve_fraction": rg["power_on_curve_fraction"],
        "temp_rate_coeff_dps_per_Cmin": rg["temp_rate_coeff_dps_per_Cmin"] / rg["bias_temp_amplitude_dps"] * g_amp,
        "g_sensitivity_dps_per_g": rg["g_sensitivity_dps_per_g"] if g_sens is None else g_sens,
        "roll_coupling_dps": tuple(v / rg["bias_temp_amplitude_dps"] * g_amp for v in rg["roll_coupling_dps"]),
        "roll_coupling_ref_dps": rg["roll_coupling_ref_dps"], "full_scale_dps": gy["range_dps"],
    }
    accel = {
        "noise_rms_mg": a_arw * math.sqrt(RATE_HZ), "noise_ref_rate_hz": RATE_HZ,
        "bias_instability_mg": a_bi, "bias_corr_time_s": ra["bias_corr_time_s"],
        "rate_random_walk_mg_per_rts": ra["rate_random_walk_mg_per_rts"] / ra["bias_instability_mg"] * a_bi,
        "lsb_mg": ac["range_g"] * 1000.0 / 32768.0,
        "initial_bias_mg": ac["initial_bias_mg"], "initial_sf_ppm": ac["initial_sf_pct"] * 1e4,
        "misalignment_deg": math.degrees(ac["cross_axis_pct"] / 100.0),
        "misalignment_tempco_deg_per_K": ra["misalignment_tempco_deg_per_K"],
        "turn_on_bias_mg": ra["turn_on_bias_mg"] / ra["bias_temp_amplitude_mg"] * a_amp,
        "bias_temp_amplitude_mg": a_amp, "sf_temp_amplitude_ppm": ac["sf_tc"] * 1e4 * SWING_K,
        "power_on_curve_fraction": ra["power_on_curve_fraction"],
        "temp_rate_coeff_mg_per_Cmin": ra["temp_rate_coeff_mg_per_Cmin"] / ra["bias_temp_amplitude_mg"] * a_amp,
        "asymmetry_ppm": ra["asymmetry_ppm"], "k2_mg_per_g2": ra["k2_mg_per_g2"],
    }
    counts = {"checked": 0, "recalled": 0, "assumed": 0}
    for part in ("gyro", "accel", "chip"):
        for _v, src in figs[part].values():
            counts[status(src)] += 1
    assumed = sorted(f"{p}.{f}" for p in ("gyro", "accel", "chip") for f, (_v, s) in figs[p].items()
                     if status(s) == "assumed")
    return {
        "description": description,
        "sources": [*sources,
                    f"figures: {counts['checked']} read in the datasheet, {counts['recalled']} recalled, not "
                    f"checked, {counts['assumed']} assumed ({', '.join(assumed) or 'none'})",
                    "datasheet -> model conversion: imutherm.imu.sensor_library (module docstring); terms no "
                    "datasheet gives scaled from the reference grade adis16355"],
        "chip": key, "figures": figs, "counts": counts,
        "sample_rate_hz": RATE_HZ,
        "temp_sensor_tau_s": ref["temp_sensor_tau_s"],
        "temp_sensor_offset_std_C": ref["temp_sensor_offset_std_C"],
        "temp_sensor_lsb_C": figs["chip"]["temp_lsb_C"][0],
        "gyro": gyro, "accel": accel,
    }


def _generic_figs() -> dict:
    out = {}
    for part, keys in (("gyro", _GYRO_KEYS), ("accel", _ACCEL_KEYS), ("chip", ("temp_lsb_C",))):
        figs = {}
        for fig in keys:
            m = _class_median(part, fig, "consumer")
            if m is not None:
                figs[fig] = (m[0], f"assumed: median of the {m[1]} consumer chips giving it")
        if part == "gyro":
            figs.setdefault("g_sensitivity_dps_per_g", (None, "assumed: the reference grade's"))
        if part != "chip":
            figs.setdefault("bi", (None, "assumed: the reference grade's ratio of bias instability to noise density"))
        out[part] = figs
    return out


def library_grades(reference: dict) -> dict:
    """Every library chip's grade dict and ``generic_mems``, keyed by chip key (e.g. ``icm42688p``).

    reference : the reference grade dict (``GRADES["adis16355"]``) for the terms no datasheet gives.
    """
    grades = {}
    for key, c in library().items():
        grades[key] = _grade(key, c["name"], f"{c['name']} ({c['maker']}), {c['class']} MEMS, from its datasheet",
                             [f"{c['maker']} {c['name']}: {c['datasheet']}", *([c["note"]] if "note" in c else [])],
                             _fill(key), reference)
    grades[GENERIC] = _grade(GENERIC, "generic consumer MEMS",
                             "generic consumer MEMS IMU: the median of the library's consumer chips' datasheet figures",
                             ["the median over the library's consumer chips of each figure they give"],
                             _generic_figs(), reference)
    return grades


# --------------------------------------------------------------------------- the chip on a board
@dataclass(frozen=True)
class GradeChoice:
    """The grade chosen for a part: ``grade`` (a GRADES key), ``chip`` (library key or None) and ``line``."""

    grade: str
    chip: str | None
    line: str


def _norm(text: str) -> str:
    return re.sub(r"\s+", "", str(text or "")).upper()


def match_chip(*texts: str) -> str | None:
    """The library key of the chip named in any of ``texts`` (part value, footprint name), or None.

    Each chip's ``match`` expressions are searched in the upper-cased text without spaces; the longest match
    wins (``LSM6DSOX`` over ``LSM6DSO``).
    """
    best, best_len = None, 0
    for text in texts:
        t = _norm(text)
        if not t:
            continue
        for key, c in library().items():
            for pat in c["match"]:
                m = re.search(pat, t)
                if m and len(m.group(0)) > best_len:
                    best, best_len = key, len(m.group(0))
    return best


def chip_source(key: str) -> str:
    """``ICM-42688-P (TDK InvenSense ICM-42688-P Datasheet DS-000347 rev 1.7)``: a chip and its datasheet."""
    c = library()[key]
    return f"{c['name']} ({c['maker']} {c['datasheet']})"


def grade_for_part(ref: str, value: str, footprint: str = "", kind: str = "imu") -> GradeChoice:
    """The grade of site part ``ref`` (a ``kind`` site) from its value or footprint: its library chip, else
    ``generic_mems``; ``line`` says which, in one line."""
    key = match_chip(value, footprint)
    if key is None:
        shown = value or footprint or "?"
        return GradeChoice(GENERIC, None, f"site {ref}={kind}: unknown chip {shown!r}: generic consumer MEMS grade "
                                          f"({GENERIC}: the median of the library's consumer chips); --grade "
                                          f"{ref}=NAME names its grade")
    return GradeChoice(key, key, f"site {ref}={kind}: {chip_source(key)}: grade {key}")


def grade_source(name: str) -> str:
    """One line naming a grade and where its figures come from (for ``compare`` and the report)."""
    from imutherm.imu.grades import GRADES

    parts = name.split("+")
    lines = []
    for p in parts:
        d = GRADES.get(p)
        if d is None:
            raise InputError(f"sensor grade: unknown grade {p!r}; valid grades: {', '.join(sorted(GRADES))}")
        if d.get("chip") in library():
            c = d["counts"]
            lines.append(f"{p}: {chip_source(d['chip'])}; {c['checked']} figures read in the datasheet, "
                         f"{c['recalled']} recalled, {c['assumed']} assumed")
        else:
            lines.append(f"{p}: {d['description']}")
    return " + ".join(lines) if len(parts) == 1 else "gyro " + lines[0] + "; accel " + lines[1]


def markdown_table() -> str:
    """The library as a Markdown table (docs/reference/sensor-library.md); each figure marked D (read in the
    datasheet), R (recalled, not checked) or A (assumed by the class rule)."""
    from imutherm.imu.grades import GRADES

    mark = {"checked": "D", "recalled": "R", "assumed": "A"}

    def cell(figs, key, fmt):
        v, src = figs[key]
        return f"{fmt(v)} {mark[status(src)]}" if v is not None else f"- {mark[status(src)]}"

    rows = ["| grade | chip | datasheet | gyro range [dps] | gyro noise [dps/rtHz] | gyro bias tempco [dps/K] | "
            "gyro SF tempco [%/K] | accel noise [ug/rtHz] | accel bias tempco [mg/K] | accel SF tempco [%/K] | "
            "figures D / R / A |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for key in [*library(), GENERIC]:
        g = GRADES[key]
        gy, ac = g["figures"]["gyro"], g["figures"]["accel"]
        c = g["counts"]
        chip = f"{library()[key]['name']} ({library()[key]['maker']})" if key in library() else "generic consumer MEMS"
        ds = library()[key]["datasheet"] if key in library() else "median of the consumer chips"
        rows.append(f"| `{key}` | {chip} | {ds} | {cell(gy, 'range_dps', lambda v: f'{v:g}')} | "
                    f"{cell(gy, 'nd', lambda v: f'{v:.4g}')} | {cell(gy, 'bias_tc', lambda v: f'{v:.3g}')} | "
                    f"{cell(gy, 'sf_tc', lambda v: f'{v:.3g}')} | {cell(ac, 'nd', lambda v: f'{v:.4g}')} | "
                    f"{cell(ac, 'bias_tc', lambda v: f'{v:.3g}')} | {cell(ac, 'sf_tc', lambda v: f'{v:.3g}')} | "
                    f"{c['checked']} / {c['recalled']} / {c['assumed']} |")
    return "\n".join(rows) + "\n"
