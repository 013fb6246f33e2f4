"""The end-to-end study's schedule over its workers (issue 59): the command's own work while the workers run the
IMU cases (``run_study``'s ``while_imu``: the report's imports, off the serial end of the run)."""

from dataclasses import replace

import pytest

from imutherm import cache
from imutherm.studies.end_to_end import StudyConfig, run_study

#: a coarse mesh, a short power-on, no estimate: a few seconds per thermal case (as tests/test_thermal_cache.py)
KW = dict(mesh_size_mm=6.0, min_cells=1, t_end=300.0, transient_model="reduced", until_settled=False)
CONFIG = StudyConfig(seeds=2, profiles=("swing",), filters=("gated",), calibrations=("unit",))


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
