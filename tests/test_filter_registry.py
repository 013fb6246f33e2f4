"""One filter registry: a filter registered in one place appears in the attitude command (profile and
log), the study (``StudyConfig``, ``imutherm compare``, the study's IMU side), the tuning procedure and the
plots; no module keeps its own list."""

import json
from dataclasses import replace

import numpy as np
import pytest

from imutherm.cli.attitude import main
from imutherm.imu.filters import GatedParams, run_ungated
from imutherm.imu.filters.registry import (GROUPS, REGISTRY, FilterSpec, Tuned, filter_names, gyro_range_filters,
                                           in_group, parse_filters, platform_tuned_filters, real_filters,
                                           reference_filter, register, study_filters, sweep_filters, tuned_filters,
                                           unregister)


def _gyro_only(x, p):
    """Liu et al. 2012's update with the gains scaled by ``p.kp`` / 0.3 (default kp 0: gyro integration from the
    leveling; a filter only a test registers)."""
    p = p or GatedParams(None, kp=0.0, ki=0.0)
    return run_ungated(x.gyro, x.accel, x.dt, replace(x.default("gated"), kp=p.kp, ki=p.ki), init_s=x.init_s)


@pytest.fixture
def gyro_only():
    register(FilterSpec("gyro_only", _gyro_only, GatedParams, "ours", "test: strapdown without correction",
                        "tab:cyan", groups={"study", "real_tuned"}, base=lambda x: GatedParams(None, kp=0.0, ki=0.0),
                        tuning=(Tuned("kp", 0.01, 0.1, (1e-3, 1.0), "kp [1/s]"),)))
    yield "gyro_only"
    unregister("gyro_only")


def test_a_filter_belongs_to_named_groups_and_the_registry_is_queried_by_group(gyro_only):
    """One field, ``groups``, says which runs a filter belongs to; each query reads a group; a group the registry
    does not know is refused when the filter is registered, and when it is asked for."""
    assert REGISTRY["gyro_only"].groups == frozenset({"study", "real_tuned"})
    assert "gyro_only" in study_filters() and "gyro_only" in real_filters() and "gyro_only" not in sweep_filters()
    assert in_group("study") == study_filters()            # none of the study group needs GNSS
    assert reference_filter() == "vqf" and platform_tuned_filters() == ("mahony",)
    assert gyro_range_filters(("vqf", "fusion", "nope")) == ("fusion",)
    assert "vqf" not in in_group("varying_dt") and "gated" in in_group("varying_dt")  # VQF's period is fixed
    assert "mahony" in tuned_filters() and "mahony" not in real_filters()  # its defaults are a trap on real motion
    for spec in REGISTRY.values():
        assert spec.groups <= set(GROUPS), spec.name
    with pytest.raises(Exception, match="group studdy unknown; valid: study, sweep"):
        register(FilterSpec("typo", _gyro_only, GatedParams, "ours", "test", "tab:cyan", groups={"studdy"}))
    assert "typo" not in REGISTRY
    with pytest.raises(Exception, match="groups must be a set of group names"):
        FilterSpec("typo", _gyro_only, GatedParams, "ours", "test", "tab:cyan", groups="study")
    with pytest.raises(Exception, match="filter group 'in_study' unknown"):
        in_group("in_study")


def test_builtin_filters_are_registered_once():
    assert {"gated", "kf", "ungated", "fusion", "aekf", "aekf_gnss", "vqf", "madgwick", "mahony", "ekf"} <= set(REGISTRY)
    assert filter_names(gnss=False) == tuple(n for n in REGISTRY if n != "aekf_gnss")
    assert filter_names(kind="peer") == ("fusion", "vqf", "madgwick", "mahony", "ekf")
    # the study's answer: ours (aekf among them) beside the peers; a sweep case's lean side: the papers' two
    assert {"gated", "kf", "ungated", "aekf", "fusion", "vqf"} <= set(study_filters())
    assert sweep_filters() == ("gated", "kf")
    assert set(study_filters()) <= set(tuned_filters())  # every filter of the answer is tuned
    # every filter with settings names its class (no name special-cases in run_filters or the settings file)
    assert all(REGISTRY[n].params_cls is not None for n in REGISTRY)
    assert all(REGISTRY[n].color for n in REGISTRY)
    with pytest.raises(Exception, match="--filters: aekf_gnss unknown or not applicable"):
        parse_filters("gated,aekf_gnss", gnss=False)


def test_registered_filter_appears_in_cli_study_and_plot(tmp_path, gyro_only, monkeypatch):
    import matplotlib.axes

    drawn = []
    orig = matplotlib.axes.Axes.plot

    def spy(self, *a, **kw):
        drawn.append((kw.get("label", ""), kw.get("color")))
        return orig(self, *a, **kw)

    monkeypatch.setattr(matplotlib.axes.Axes, "plot", spy)
    out = tmp_path / "p"
    assert main(["--profile", "static", "--duration", "30", "--filters", "gated,gyro_only,vqf",
                 "--out", str(out)]) == 0
    d = json.loads((out / "attitude.json").read_text())
    assert set(d["filters"]) == {"gated", "gyro_only", "vqf"}
    assert np.isfinite(d["filters"]["gyro_only"]["overall"]["roll_rms_deg"]["mean"])
    assert any(lbl.startswith("gyro_only") and c == "tab:cyan" for lbl, c in drawn)
    # the study report's attitude curves: every filter of the study, in the registry's colour
    from matplotlib.backends.backend_pdf import PdfPages

    from imutherm.reports import study_report

    drawn.clear()
    rows = np.column_stack([np.arange(5.0), np.zeros((5, 4))])
    np.savetxt(tmp_path / "attitude_air.csv", rows, delimiter=",", comments="",
               header="time_s,gated_roll_err_deg,gated_pitch_err_deg,gyro_only_roll_err_deg,gyro_only_pitch_err_deg")
    with PdfPages(tmp_path / "r.pdf") as pdf:
        study_report._attitude_page(pdf, tmp_path, {"schemes": {"air": {}}, "filter_settings": {},
                                                    "study": {"compensations": ["improved"],
                                                              "filters": ["gated", "gyro_only"]}})
    assert ("gyro_only", "tab:cyan") in drawn and ("gated", "tab:blue") in drawn
    # a recorded log: the default runs every registered filter that applies, the new one included
    from imutherm.imu.imu_log import write_imu_csv
    rng = np.random.default_rng(0)
    n = 2000
    p = write_imu_csv(tmp_path / "rest.csv", np.arange(n) * 0.01, rng.normal(0, 1e-3, (n, 3)),
                      np.array([0.0, 0.0, -9.80665]) + rng.normal(0, 0.02, (n, 3)))
    assert main(["--imu-csv", str(p), "--out", str(tmp_path / "l"), "--no-plot"]) == 0
    d = json.loads((tmp_path / "l" / "attitude.json").read_text())
    assert "gyro_only" in d["filters"] and "aekf_gnss" not in d["filters"]


def test_registered_filter_appears_in_the_study_compare_and_the_tuner(gyro_only):
    """A filter registered with ``in_study`` and tuning axes is in the study's default configuration, the
    default of ``imutherm compare --filters``, the study's IMU side (at its tuned setting when the settings
    file has one), and the tuning procedure (the study's settings and bench_attitude's), which tunes it on the
    registry's axes."""
    import dataclasses

    from imutherm.cli import build_parser
    from imutherm.cli.compare import _study_config
    from imutherm.studies.attitude import filter_settings as fs
    from imutherm.studies.attitude import filter_tuning
    from imutherm.studies.end_to_end import StudyConfig, imu_case

    assert "gyro_only" in StudyConfig().filters and "gyro_only" in study_filters()
    args = build_parser("compare").parse_args(["compare", "--out", "unused"])
    assert "gyro_only" in _study_config(args).filters
    assert "gyro_only" in tuned_filters()
    r = filter_tuning.tune(profiles=("swing",), seeds=(100,), filters=("gyro_only",), log=lambda *a: None)
    best = r["swing"]["gyro_only"]
    assert best["values"]["kp"] > 0 and best["score"] < best["default_score"]  # a correction beats none
    # the held-out benchmark (bench_attitude) tunes and runs it by the same procedure, no list of its own
    from imutherm.studies.attitude import filter_benchmark as fb

    recs = fb.make_records((("swing", (100,)),))
    assert fb.tune("gyro_only", recs).values["kp"] > 0
    # the study's IMU side runs it, at its tuned value when the settings file carries one
    base = fs.load_settings()
    prof = {p: dict(by) for p, by in base.profiles.items()}
    prof["swing"]["gyro_only"] = dict(best["values"])
    tuned = dataclasses.replace(base, profiles=prof)
    cfg = StudyConfig(seeds=1, profiles=("swing",), compensations=("improved",), calibrations=("unit",))
    t = np.array([0.0, 400.0])
    T = np.array([[70.0] * 6, [75.0] * 6])

    def case():
        return imu_case("adis16355", 3, t, T, T[-1], np.array([-40.0, 70.0]), np.full((2, 6), 5.0), cfg)
    import unittest.mock as mock

    with mock.patch.object(fs, "load_settings", lambda path=None: tuned):
        a = case()["attitude"]["unit"]["steady"]["improved"]["gyro_only"]["swing"]
    b = case()["attitude"]["unit"]["steady"]["improved"]["gyro_only"]["swing"]  # the file has no gyro_only: kp 0
    assert a["roll_rms_deg"] < b["roll_rms_deg"]


def test_unknown_filter_is_refused(tmp_path, capsys):
    assert main(["--profile", "static", "--duration", "30", "--filters", "gated,nope", "--out",
                 str(tmp_path / "x")]) == 2
    assert "--filters: nope unknown" in capsys.readouterr().err
