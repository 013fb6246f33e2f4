"""One filter registry: a filter registered in one place appears in the attitude command (profile and
log), the study and the plots."""

import json
from dataclasses import replace

import numpy as np
import pytest

from imutherm.cli.attitude import main
from imutherm.imu.filters import ALL_FILTERS, run_ungated
from imutherm.imu.filters.registry import REGISTRY, FilterSpec, filter_names, parse_filters, register, unregister


def _gyro_only(x, p):
    """The seed update with zero gains: gyro integration from the leveling (a filter only a test registers)."""
    return run_ungated(x.gyro, x.accel, x.dt, replace(x.gated, kp=0.0, ki=0.0), init_s=x.init_s)


@pytest.fixture
def gyro_only():
    register(FilterSpec("gyro_only", _gyro_only, None, "ours", "test: strapdown without correction", "tab:cyan"))
    yield "gyro_only"
    unregister("gyro_only")


def test_builtin_filters_are_registered_once():
    assert set(ALL_FILTERS) <= set(REGISTRY)
    assert filter_names(gnss=False) == tuple(n for n in REGISTRY if n != "aekf_gnss")
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
    # a recorded log: the default runs every registered filter that applies, the new one included
    from imutherm.imu.imu_log import write_imu_csv
    rng = np.random.default_rng(0)
    n = 2000
    p = write_imu_csv(tmp_path / "rest.csv", np.arange(n) * 0.01, rng.normal(0, 1e-3, (n, 3)),
                      np.array([0.0, 0.0, -9.80665]) + rng.normal(0, 0.02, (n, 3)))
    assert main(["--imu-csv", str(p), "--out", str(tmp_path / "l"), "--no-plot"]) == 0
    d = json.loads((tmp_path / "l" / "attitude.json").read_text())
    assert "gyro_only" in d["filters"] and "aekf_gnss" not in d["filters"]


def test_unknown_filter_is_refused(tmp_path, capsys):
    assert main(["--profile", "static", "--duration", "30", "--filters", "gated,nope", "--out",
                 str(tmp_path / "x")]) == 2
    assert "--filters: nope unknown" in capsys.readouterr().err
