"""The filters' real-motion settings (``imutherm attitude --imu-csv --platform handheld``), read from
``real_settings.toml`` beside this module.

Written by ``benchmarks/bench_real_motion.py --write`` (:mod:`imutherm.studies.attitude.real_tuning`): every filter with
tuning axes, ours and the peers, tuned by the one procedure (:mod:`imutherm.studies.attitude.filter_tuning`) on the nine
real development files (RepoIMU and BROAD), with the physical base settings of
:data:`~imutherm.studies.attitude.real_tuning.BASE` beside the tuned axes. The file holds per filter the values, the
grid, the per-file scores, the cross-validated scores (each file scored by the setting tuned on the other
eight), the date and the command:
the values are a *development* choice (fitted on the files they are scored on); the cross-validated figures are
the evidence that they generalise.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

from imutherm import InputError

REAL_SETTINGS_PATH = Path(__file__).with_name("real_settings.toml")


@dataclass(frozen=True)
class RealSettings:
    """path : str; meta : dict (procedure, objective, data, folds, date, command); values : {filter: {field: value}};
    entries : {filter: the whole table (values, grid, scores, cross-validated scores)}."""

    path: str
    meta: dict
    values: dict = field(repr=False)
    entries: dict = field(repr=False)

    def for_names(self, names) -> dict:
        """{filter: {field: value}} of ``names`` (a filter not in the file: absent, i.e. its library defaults)."""
        return {n: dict(self.values[n]) for n in names if n in self.values}


def parse_real_settings(data: dict, path: str = "<dict>") -> RealSettings:
    """Check the TOML content (every value a field of the filter's registry ``params_cls``) and build
    :class:`RealSettings`; one-line InputError naming the file, the filter and the field."""
    from imutherm.studies.attitude.filter_settings import checked_values

    meta = data.get("meta", {})
    values, entries = {}, {}
    for name, entry in data.items():
        if name == "meta":
            continue
        values[name] = checked_values(f"{path}: [{name}]", name, entry)
        entries[name] = dict(entry)
    return RealSettings(str(path), dict(meta), values, entries)


@lru_cache(maxsize=4)
def _load(path: str) -> RealSettings:
    from imutherm.studies.attitude.filter_settings import read_toml

    return parse_real_settings(read_toml(path, "real-motion settings", "benchmarks/bench_real_motion.py --write"), path)


def load_real_settings(path=None) -> RealSettings:
    """Read (cached) the real-motion settings (default :data:`REAL_SETTINGS_PATH`)."""
    return _load(str(REAL_SETTINGS_PATH if path is None else Path(path)))


def real_motion_lines(names, path=None) -> list:
    """A short table of ``names`` on real motion, to print beside a simulated answer: each filter's cross-validated
    mean inclination RMS [deg] over the real development files at its real-motion settings, its ratio to VQF's
    (the same procedure) and its worst file's ratio to VQF on that file; [] without the settings file. Filters the
    file does not hold are left out."""
    try:
        rs = load_real_settings(path)
    except InputError:
        return []
    e = rs.entries
    from imutherm.imu.filters.registry import reference_filter

    ref = reference_filter()  # the peer the others are set against
    vq = e.get(ref, {}).get("cv_mean")
    def worst(n):  # the worst file's ratio to VQF on that file (cross-validated), beside the mean's
        w = e[n].get("cv_worst_x_vqf")
        return f", worst file {w:.2f}x" if w is not None else ""

    cells = [f"{n} {e[n]['cv_mean']:.2f}" + (f" ({e[n]['cv_mean'] / vq:.2f}x {ref}{worst(n)})" if vq and n != ref
                                              else "")
             for n in names if n in e and "cv_mean" in e[n]]
    if not cells:
        return []
    files = rs.meta.get("files", [])
    head = (f"the same filters on real motion: inclination RMS [deg], mean of {len(files)} real development files "
            f"(RepoIMU pendulum, BROAD), each at its real-motion settings, cross-validated by file "
            f"({Path(rs.path).name}, {rs.meta.get('date', '')}; docs: benchmarks/real_motion)")
    return [head] + ["  " + " | ".join(cells[i:i + 4]) for i in range(0, len(cells), 4)]
