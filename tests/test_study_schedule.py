"""The end-to-end study's schedule over its workers (issue 59): the order the thermal cases go to the workers
(the longest beside the shortest, so their refined solves, one at a time, do not fall together) and the command's
own work while the workers run the IMU cases (``run_study``'s ``while_imu``)."""

from dataclasses import replace

import pytest

from imutherm import cache
from imutherm.geometry.layout import load_layout
from imutherm.studies.end_to_end import StudyConfig, run_study
from imutherm.studies.end_to_end.run import worker_order
from imutherm.studies.thermal.thermal_study import longest_first
from imutherm.unit.model import ModelOptions

#: a coarse mesh, a short power-on, no estimate: a few seconds per thermal case (as tests/test_thermal_cache.py)
KW = dict(mesh_size_mm=6.0, min_cells=1, t_end=300.0, transient_model="reduced", until_settled=False)
CONFIG = StudyConfig(seeds=2, profiles=("swing",), filters=("gated",), calibrations=("unit",))


def test_worker_order_starts_the_longest_beside_the_shortest():
    lay, opt = load_layout(None), ModelOptions()
    schemes = ("air", "grease", "potted")
    # air and grease exchange radiation across their air cavity (s2s): the longest; potted the shortest
    assert longest_first(lay, schemes, opt) == ("air", "grease", "potted")
    assert worker_order(lay, schemes, opt, 2) == ("air", "potted", "grease")
    assert worker_order(lay, ("potted", "grease", "air"), opt, 2) == ("grease", "potted", "air")
    # one worker, or a worker for every case: all start at once or one after another, the order as before
    for jobs in (1, 3, 4):
        assert worker_order(lay, schemes, opt, jobs) == longest_first(lay, schemes, opt)
    assert worker_order(lay, ("grease", "potted"), opt, 2) == ("grease", "potted")
    assert worker_order(lay, ("potted",), opt, 2) == ("potted",)


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path / "c"))
    monkeypatch.delenv(cache.ENABLE_ENV, raising=False)
    return tmp_path / "c"


def test_while_imu_runs_once_with_workers_and_not_alone(folder):
    calls = []
    first = run_study(None, ("potted",), config=CONFIG, jobs=2, while_imu=lambda: calls.append("w"), **KW)
    assert calls == ["w"]   # two IMU cases: two workers; called once, every thermal case in
    again = run_study(None, ("potted",), config=CONFIG, jobs=1, while_imu=lambda: calls.append("1"), **KW)
    assert calls == ["w"]   # one process: nothing runs beside it, the function is not called
    assert again.schemes["potted"].imu == first.schemes["potted"].imu
    one = replace(CONFIG, seeds=1)   # one IMU case: one worker is all it can use, so no pool
    run_study(None, ("potted",), config=one, jobs=2, while_imu=lambda: calls.append("x"), **KW)
    assert calls == ["w"]
