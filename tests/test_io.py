"""The one JSON writer and the one single-file atomic writer (issue 13 §2)."""

import json

import numpy as np
import pytest

from imutherm.io import atomic_write, write_json


def test_write_json_converts_numpy_and_non_finite(tmp_path):
    data = {"a": np.float32(1.5), "b": np.arange(3), 4: [np.nan, np.inf, 2.0]}
    write_json(tmp_path / "x.json", data)
    assert json.loads((tmp_path / "x.json").read_text()) == {"a": 1.5, "b": [0, 1, 2], "4": [None, None, 2.0]}
    write_json(tmp_path / "y.json", data, finite=False, indent=1)   # Calibration.save_json keeps NaN
    back = json.loads((tmp_path / "y.json").read_text())
    assert np.isnan(back["4"][0]) and back["4"][1] == np.inf


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "r.json"
    write_json(path, {"v": 1})

    def broken(tmp):
        with open(tmp, "w") as fh:
            fh.write("{half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        atomic_write(path, broken)
    assert json.loads(path.read_text()) == {"v": 1} and [p.name for p in tmp_path.iterdir()] == ["r.json"]
    with pytest.raises(TypeError):          # not serialisable: refused before the file is touched
        write_json(path, {"v": object()})
    assert json.loads(path.read_text()) == {"v": 1} and [p.name for p in tmp_path.iterdir()] == ["r.json"]
