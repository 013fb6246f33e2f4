"""The study's tuned filter settings (studies/attitude/filter_settings.toml): read, checked, applied; page 1 of the report.

The file itself is produced by benchmarks/tune_study_filters.py; these tests check that it carries its
provenance, that its grids are the script's, that the study runs each filter at the file's value (a spy
registered in the filter's place records what it ran with), and that bad files are refused in one line.
"""

import dataclasses

import numpy as np
import pytest

from imutherm import InputError
from imutherm.imu.filters import registry
from imutherm.studies.attitude import filter_settings as fs
from imutherm.studies.attitude import filter_tuning as tuner

STUDY_FILTERS = ("gated", "kf", "ungated", "aekf", "fusion", "vqf")  # the answer shows at least these


def test_committed_file_has_every_study_filter_with_its_provenance():
    s = fs.load_settings()
    from imutherm.studies.end_to_end import StudyConfig

    cfg = StudyConfig()
    assert set(STUDY_FILTERS) <= set(cfg.filters) == set(registry.study_filters()) and cfg.tuned
    for key in ("procedure", "objective", "data", "seeds", "command"):
        assert s.meta[key], key
    answer_seeds = set(range(cfg.seed0, cfg.seed0 + cfg.seeds))
    assert not answer_seeds & set(s.meta["seeds"])  # tuned on data the answer is not computed on
    for prof in cfg.profiles:
        for name in cfg.filters:
            p = s.provenance[prof][name]
            for key in fs.PROVENANCE:
                assert p[key] not in (None, "", []), (prof, name, key)
            assert not answer_seeds & set(p["seeds"])
            # the chosen value is the best of its grid and the defaults
            assert p["score"] == pytest.approx(min(min(p["scores"]), p["default_score"]), abs=1e-4)
            assert p["score"] <= p["default_score"] + 1e-4
            cls = fs.target_class(name)
            assert set(s.profiles[prof][name]) <= {f.name for f in dataclasses.fields(cls)}


def test_file_grids_are_the_procedure_s_with_every_choice_inside_its_grid():
    """The file was written by the procedure on the registry's current axes (else rerun the script): every grid
    value on the one ladder, the start span inside the grid, the choice a point of the grid and never on an
    open edge of an axis (interior, a mode value, or at a bound the file names)."""
    s = fs.load_settings()
    for prof, by in s.provenance.items():
        for name, p in by.items():
            axes = registry.REGISTRY[name].tuning
            assert list(p["grid"]) == [tuner.label(ax) for ax in axes], (prof, name)
            if p["chosen"] == "defaults":  # the published defaults beat every grid point
                assert s.profiles[prof][name] == tuner.default_values(name) and p["score"] < min(p["scores"])
            else:
                assert s.profiles[prof][name] in tuner.grid_points(p["grid"])
            for ax, vals in zip(axes, p["grid"].values()):
                lead = [v[0] if isinstance(v, list) else v for v in vals]
                ladder = [v for v in lead if v not in ax.off]
                assert all(ax.value(ax.rung(v)) == pytest.approx(v) for v in ladder), (prof, name, ax.field)
                ks = [ax.rung(v) for v in ladder]
                assert ks == list(range(ks[0], ks[-1] + 1)) and set(ax.start()) <= set(ks), (prof, name, ax.field)
                chosen = s.profiles[prof][name][ax.field]
                if p["chosen"] == "defaults" or chosen in ax.off or ks[0] < ax.rung(chosen) < ks[-1]:
                    continue
                assert ax.field in p["at_bound"] and not ax.within(ax.rung(chosen) + (1 if ax.rung(chosen) == ks[-1]
                                                                                         else -1)), (prof, name)


def test_the_search_grows_an_axis_until_its_best_is_inside_and_stops_at_a_bound():
    calls = []

    def bowl(pt):  # its minimum at gain 10^2.5 = 316, beyond the start span 1..10; mode value 0 worse
        calls.append(dict(pt))
        g = pt["gain"]
        return 5.0 if g == 0.0 else (np.log10(g) - 2.5) ** 2 + 0.1 * abs(np.log10(pt["tau"]) - 0.5)

    axes = (registry.Tuned("gain", 1.0, 10.0, (0.01, 1e4), "a gain", off=(0.0,)),
            registry.Tuned("tau", 1.0, 3.16, (0.1, 100.0), "a time constant"))
    r = tuner.search(axes, bowl)
    assert r["values"] == {"gain": 316.0, "tau": 3.16} and r["at_bound"] == []
    assert r["grid"]["gain"][0] == 0.0 and r["grid"]["gain"][-1] == 1000.0  # grown one past the best
    assert len(calls) == r["evaluations"] == len({tuple(sorted(c.items())) for c in calls})  # each point once
    assert r["scores"][tuner.grid_points(r["grid"]).index(r["values"])] == r["score"] == min(r["scores"])
    bounded = (registry.Tuned("gain", 1.0, 10.0, (0.01, 100.0), "a gain"),)
    r = tuner.search(bounded, lambda pt: -pt["gain"])
    assert r["values"] == {"gain": 100.0} and r["at_bound"] == ["gain"]
    with pytest.raises(InputError, match="bounds"):
        registry.Tuned("gain", 1.0, 10.0, (2.0, 100.0), "a gain")


def test_every_tuned_filter_is_declared_in_the_registry_and_the_study_s_are_tuned():
    """The tuning script reads the registry: a filter registered with axes is tuned, and every filter of the
    study's answer has axes (so none runs at a setting nobody searched)."""
    from imutherm.studies.end_to_end import StudyConfig

    assert set(StudyConfig().filters) <= set(registry.tuned_filters())
    saved = dict(registry.REGISTRY)
    try:
        registry.register(dataclasses.replace(saved["vqf"], name="vqf_copy"))
        assert "vqf_copy" in registry.tuned_filters()
    finally:
        registry.REGISTRY.clear()
        registry.REGISTRY.update(saved)


def test_grid_points_split_paired_fields():
    pts = tuner.grid_points({"a": [1, 2], "b+c": [(3, 4), (5, 6)]})
    assert pts == [{"a": 1, "b": 3, "c": 4}, {"a": 1, "b": 5, "c": 6}, {"a": 2, "b": 3, "c": 4},
                   {"a": 2, "b": 5, "c": 6}]


@pytest.fixture
def spy():
    """Replace registered filters by spies that record the parameters they ran with (restored after)."""
    seen = {}
    saved = dict(registry.REGISTRY)

    def install(name, pick):
        orig = saved[name]

        def run(x, p):
            seen.setdefault(name, []).append(pick(x, p))
            return orig.run(x, p)
        registry.register(dataclasses.replace(orig, run=run))

    yield seen, install
    registry.REGISTRY.clear()
    registry.REGISTRY.update(saved)


def _swing_case(filters, tuned=True):
    from imutherm.studies.end_to_end import StudyConfig, imu_case

    cfg = StudyConfig(seeds=1, profiles=("swing",), filters=filters, compensations=("improved",),
                      calibrations=("unit",), tuned=tuned)
    t = np.array([0.0, 400.0])
    T = np.array([[70.0] * 6, [75.0] * 6])
    return imu_case("adis16355", 3, t, T, T[-1], np.array([-40.0, 70.0]), np.full((2, 6), 5.0), cfg)


def test_study_runs_each_filter_at_the_file_value(spy):
    seen, install = spy
    file = fs.load_settings().profiles["swing"]
    install("vqf", lambda x, p: p)
    install("gated", lambda x, p: p or x.default("gated"))
    install("kf", lambda x, p: p or x.default("kf"))
    install("ungated", lambda x, p: p or x.default("ungated"))
    _swing_case(("gated", "kf", "ungated", "vqf"))
    for name in ("vqf", "gated", "kf", "ungated"):
        assert seen[name], name
        for p in seen[name]:
            for k, v in file[name].items():
                assert getattr(p, k) == pytest.approx(v), (name, k)
    # and the defaults when told so
    seen.clear()
    _swing_case(("vqf",), tuned=False)
    assert all(p is None for p in seen["vqf"])


def test_changing_the_file_value_changes_the_study(monkeypatch):
    base = fs.load_settings()

    def with_tau(tau):
        prof = {p: {n: dict(v) for n, v in by.items()} for p, by in base.profiles.items()}
        prof["swing"]["vqf"] = {"tauAcc": tau}
        return dataclasses.replace(base, profiles=prof)

    monkeypatch.setattr(fs, "load_settings", lambda path=None: with_tau(1.0))
    a = _swing_case(("vqf",))["attitude"]["unit"]["steady"]["improved"]["vqf"]["swing"]
    monkeypatch.setattr(fs, "load_settings", lambda path=None: with_tau(1000.0))
    b = _swing_case(("vqf",))["attitude"]["unit"]["steady"]["improved"]["vqf"]["swing"]
    assert a["roll_rms_deg"] != b["roll_rms_deg"]


@pytest.mark.parametrize("entry, message", [
    ({"values": {"tauAcc": 3.0, "speed": 1.0}, "grid": {}, "seeds": [100], "score": 1.0, "command": "x"},
     "[flight.vqf]: speed not a VQFParams field"),
    ({"values": {"tauAcc": 3.0}, "grid": {}, "score": 1.0, "command": "x"}, "provenance seeds missing"),
    ({"grid": {}, "seeds": [100], "score": 1.0, "command": "x"}, "'values' missing"),
])
def test_bad_settings_are_refused_in_one_line(entry, message):
    with pytest.raises(InputError) as e:
        fs.parse_settings({"flight": {"vqf": entry}}, "s.toml")
    assert message in str(e.value) and str(e.value).startswith("s.toml") and "\n" not in str(e.value)
    with pytest.raises(InputError, match="filter 'magic' is unknown"):
        fs.parse_settings({"flight": {"magic": {"values": {}}}}, "s.toml")


def test_missing_file_is_refused(tmp_path):
    with pytest.raises(InputError, match="not found"):
        fs.load_settings(tmp_path / "none.toml")


def _answer_data(filters=("gated", "kf", "vqf")):
    schemes = {}
    for i, name in enumerate(("air", "grease", "potted")):
        att = {ph: {c: {f: {"flight": {m: {"mean": 0.3 + 0.1 * i + 0.05 * k, "std": 0.05} for m in
                                        ("roll_rms_deg", "pitch_rms_deg", "roll_max_deg", "pitch_max_deg")}}
                            for k, f in enumerate(filters)} for c in ("conventional", "improved")}
               for ph in ("warmup", "steady")}
        schemes[name] = {"answer": f"{name}: a sentence.", "attitude": att}
    return {"layout": "reference", "ambient_C": 70.0, "power_W": 1.0, "seeds": [0, 1, 2],
            "out_of_range_policy": "linear", "schemes": schemes,
            "filter_settings": {"tuned": True, "file": "studies/attitude/filter_settings.toml", "meta": {"seeds": [100, 101]}},
            "study": {"grade": "adis16355", "profiles": ["flight"], "compensations": ["conventional", "improved"],
                      "filters": list(filters)}}


def test_page_one_is_the_answer_figure_and_the_table_follows(tmp_path):
    from matplotlib.backends.backend_pdf import PdfPages
    from pypdf import PdfReader

    from imutherm.reports import study_report as sr

    data = _answer_data()
    with PdfPages(tmp_path / "r.pdf") as pdf:
        sr._answer_page(pdf, data)
        sr._answer_table_page(pdf, data)
    pages = PdfReader(tmp_path / "r.pdf").pages
    first, second = pages[0].extract_text(), pages[1].extract_text()
    for text in ("Which cooling scheme", "compensation: improved", "roll RMS [deg], warm-up", "pitch RMS",
                 "air", "potted", "vqf", "tuned on seeds 100, 101"):
        assert text in first, text
    assert "warm-up roll" not in first  # no table on page 1
    assert "warm-up roll" in second and "The answer in numbers" in second


def test_the_attitude_command_runs_the_tuned_settings_of_its_profile(spy, tmp_path, capsys):
    """``imutherm attitude --profile swing`` runs each filter at the file's swing values (a spy records what kf
    and vqf ran with); ``--filter-defaults`` and the untuned profile (static: at rest) run the defaults, and
    attitude.json says which."""
    import json

    from imutherm.cli import attitude as cli

    seen, install = spy
    install("kf", lambda x, p: p or x.default("kf"))
    install("vqf", lambda x, p: p)
    file = fs.load_settings().profiles["swing"]
    assert cli.main(["--profile", "swing", "--duration", "40", "--filters", "kf,vqf", "--no-plot",
                     "--out", str(tmp_path / "t")]) == 0
    j = json.loads((tmp_path / "t" / "attitude.json").read_text())["filter_settings"]
    assert j["tuned"] == {n: file[n] for n in ("kf", "vqf")} and j["defaults"] == []
    assert all(getattr(seen["kf"][0], k) == pytest.approx(v) for k, v in file["kf"].items())
    assert "filters at tuned settings" in capsys.readouterr().out
    seen.clear()
    assert cli.main(["--profile", "swing", "--duration", "40", "--filters", "vqf", "--no-plot", "--filter-defaults",
                     "--out", str(tmp_path / "d")]) == 0
    assert seen["vqf"] == [None]
    j = json.loads((tmp_path / "d" / "attitude.json").read_text())["filter_settings"]
    assert j["tuned"] == {} and j["defaults"] == ["vqf"]
    assert cli.main(["--profile", "static", "--duration", "30", "--filters", "vqf", "--no-plot",
                     "--out", str(tmp_path / "v")]) == 0
    j = json.loads((tmp_path / "v" / "attitude.json").read_text())["filter_settings"]
    assert j["tuned"] == {} and j["defaults"] == ["vqf"] and j["file"].endswith("filter_settings.toml")
