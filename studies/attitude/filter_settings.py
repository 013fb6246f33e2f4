"""The attitude filters' tuned settings for the study, read from ``filter_settings.toml`` beside this module.

Every filter of the study's answer runs at its *fair best*: one procedure for ours and the peers
(:mod:`benchmarks.tune_study_filters`, which writes the file): each filter's tuning axes, declared in the
registry (:class:`imutherm.imu.filters.registry.Tuned`), on one x3.16 ladder for every parameter, the product
grown while the best lies on its edge, scored by the mean roll/pitch RMS on simulated-profile seeds the study's
answer is not computed on. The file holds, per profile and filter, the chosen values, the grid tried, the axes
whose best sits at a bound, the tuning seeds, the scores and the command that produced them.

The values are fields of the object a filter's runner reads, its registry ``params_cls``
(:func:`imutherm.studies.attitude.attitude_study.run_filters` applies them with :func:`dataclasses.replace` to what the
registry's ``base`` derives from the record: ``gated`` / ``ungated`` :class:`GatedParams` after the thresholds
are set from the rest window, ``kf`` :class:`KFParams` before its rest-window levels are added).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

from imutherm import InputError

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    import tomli as tomllib

SETTINGS_PATH = Path(__file__).with_name("filter_settings.toml")
#: provenance fields every tuned entry must carry
PROVENANCE = ("grid", "seeds", "score", "command")


def target_class(name: str):
    """The dataclass whose fields a filter's settings name, its registry ``params_cls`` (InputError for an
    unknown filter or one that takes no settings)."""
    from imutherm.imu.filters.registry import REGISTRY

    spec = REGISTRY.get(name)
    if spec is None or spec.params_cls is None:
        raise InputError(f"filter settings: filter {name!r} is unknown; valid: {', '.join(REGISTRY)}")
    return spec.params_cls


def checked_values(where: str, name: str, entry) -> dict:
    """A settings entry's ``values`` table for filter ``name``, every key a field of its registry ``params_cls``;
    otherwise a one-line InputError that starts with ``where`` (the file and the entry)."""
    cls = target_class(name)
    values = entry.get("values") if isinstance(entry, dict) else None
    if not isinstance(values, dict):
        raise InputError(f"{where} 'values' missing; valid: a table of {cls.__name__} fields")
    fields = {f.name for f in dataclasses.fields(cls)}
    bad = [k for k in values if k not in fields]
    if bad:
        raise InputError(f"{where} {', '.join(bad)} not a {cls.__name__} field; valid: {', '.join(sorted(fields))}")
    return dict(values)


def read_toml(path: str, what: str, writer: str) -> dict:
    """The TOML file ``path`` as a dict; a one-line InputError naming ``what`` it holds for a file missing (and
    the ``writer`` that writes it) or not valid TOML."""
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise InputError(f"{what}: {path} not found; valid: a TOML file written by {writer}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{what}: {path} is not valid TOML ({exc})") from None


@dataclass(frozen=True)
class FilterSettings:
    """Tuned filter settings.

    path : str                 the file read
    meta : dict                file-level provenance (procedure, objective, data, date, command)
    profiles : dict            profile -> filter -> {field: value}
    provenance : dict          profile -> filter -> {grid, seeds, score, command, ...}
    """

    path: str
    meta: dict
    profiles: dict = field(repr=False)
    provenance: dict = field(repr=False)

    def for_profile(self, profile: str, names) -> dict:
        """{filter: {field: value}} of ``names`` on ``profile`` (filters not in the file: absent, i.e. their
        defaults)."""
        by = self.profiles.get(profile, {})
        return {n: dict(by[n]) for n in names if n in by}


def parse_settings(data: dict, path: str = "<dict>") -> FilterSettings:
    """Check the TOML content and build :class:`FilterSettings`; one-line InputError naming the file, the
    profile, the filter and the field on anything wrong."""
    meta = data.get("meta", {})
    if not isinstance(meta, dict):
        raise InputError(f"{path}: [meta] must be a table")
    profiles, prov = {}, {}
    for prof, filters in data.items():
        if prof == "meta":
            continue
        if not isinstance(filters, dict):
            raise InputError(f"{path}: [{prof}] must be a table of filters")
        for name, entry in filters.items():
            where = f"{path}: [{prof}.{name}]"
            values = checked_values(where + ":", name, entry)
            missing = [k for k in PROVENANCE if k not in entry]
            if missing:
                raise InputError(f"{where}: provenance {', '.join(missing)} missing; valid entries carry "
                                 f"{', '.join(PROVENANCE)}")
            profiles.setdefault(prof, {})[name] = values
            prov.setdefault(prof, {})[name] = {k: v for k, v in entry.items() if k != "values"}
    return FilterSettings(str(path), dict(meta), profiles, prov)


@lru_cache(maxsize=8)
def _load(path: str) -> FilterSettings:
    return parse_settings(read_toml(path, "filter settings", "benchmarks/tune_study_filters.py"), path)


def load_settings(path=None) -> FilterSettings:
    """Read (cached) the settings file (default :data:`SETTINGS_PATH`)."""
    return _load(str(SETTINGS_PATH if path is None else Path(path)))
