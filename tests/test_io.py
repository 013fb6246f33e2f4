"""The one JSON writer, the one single-file atomic writer and the folder moves beside it (one home for each
file operation)."""

import json

import numpy as np
import pytest

from imutherm.io import atomic_write, atomic_write_bytes, exchange_folders, move_staged, write_json


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


def test_atomic_write_bytes_replaces_and_a_failed_write_keeps_the_old_bytes(tmp_path):
    path = tmp_path / "e.pkl"
    atomic_write_bytes(path, b"old")
    assert atomic_write_bytes(path, b"new", tmp_prefix=".tmp-") == path and path.read_bytes() == b"new"
    with pytest.raises(TypeError):          # not bytes: raised by the writer, after the temporary file exists
        atomic_write_bytes(path, "text", tmp_prefix=".tmp-")
    assert path.read_bytes() == b"new" and [p.name for p in tmp_path.iterdir()] == ["e.pkl"]

    def interrupted(tmp):
        with open(tmp, "wb") as fh:
            fh.write(b"ha")
        raise KeyboardInterrupt             # e.g. Ctrl-C half-way: BaseException, not Exception

    with pytest.raises(KeyboardInterrupt):
        atomic_write(path, interrupted, tmp_prefix=".tmp-")
    assert path.read_bytes() == b"new" and [p.name for p in tmp_path.iterdir()] == ["e.pkl"]


def test_move_staged_replaces_namesakes_and_keeps_the_rest(tmp_path):
    out, staged = tmp_path / "out", tmp_path / "out" / ".staged"
    (out / "sub").mkdir(parents=True)
    (out / "sub" / "old.txt").write_text("old")
    (out / "a.txt").write_text("old a")
    (out / "keep.txt").write_text("keep")
    staged.mkdir()
    (staged / "a.txt").write_text("new a")
    (staged / "sub").mkdir()
    (staged / "sub" / "new.txt").write_text("new")
    assert sorted(move_staged(staged, out)) == ["a.txt", "sub"]
    assert (out / "a.txt").read_text() == "new a" and (out / "keep.txt").read_text() == "keep"
    assert [p.name for p in (out / "sub").iterdir()] == ["new.txt"] and list(staged.iterdir()) == []


def test_exchange_folders_swaps_two_folders_in_one_step(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (a / "x").write_text("from a")
    (b / "y").write_text("from b")
    if not exchange_folders(a, b):
        pytest.skip("renameat2(RENAME_EXCHANGE) is unavailable here")
    assert [p.name for p in a.iterdir()] == ["y"] and [p.name for p in b.iterdir()] == ["x"]
    with pytest.raises(OSError):            # a real failure is an error, not "unsupported"
        exchange_folders(a, tmp_path / "missing")
