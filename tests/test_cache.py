"""The disk cache of reduced models and re-runs (imutherm.cache) and its use by the correlation's build step."""

from dataclasses import dataclass, replace

import numpy as np
import pytest

from imutherm import cache
from imutherm.unit.model import ModelOptions


@dataclass(frozen=True)
class _Model:
    A: np.ndarray
    names: tuple
    x: float


def _value(seed=0):
    rng = np.random.default_rng(seed)
    return _Model(rng.normal(size=(40, 40)), ("a", "b"), 0.1 + seed)


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path / "c"))
    return tmp_path / "c"


def test_hit_returns_an_identical_value(folder):
    built = []

    def build():
        built.append(1)
        return _value()
    v1, hit1 = cache.cached("m", ("air", 70.0), build)
    v2, hit2 = cache.cached("m", ("air", 70.0), build)
    assert (hit1, hit2) == (False, True) and len(built) == 1
    assert np.array_equal(v1.A, v2.A) and v1.names == v2.names and v1.x == v2.x
    assert cache.cached("m", ("air", 70.0), build, use_cache=False)[1] is False and len(built) == 2


def test_any_key_change_misses():
    base = ("air", 70.0, 2.0, ModelOptions(), np.arange(3.0), {"h": 1.0})
    k0 = cache.key_of("reduced_model", *base)
    assert k0 == cache.key_of("reduced_model", *base)   # deterministic
    changed = [("grease",) + base[1:], ("air", 70.0 + 1e-9) + base[2:], base[:2] + (3.0,) + base[3:],
               base[:3] + (ModelOptions(cavity_law="effective"),) + base[4:],
               base[:4] + (np.array([0.0, 1.0, 2.5]),) + base[5:], base[:5] + ({"h": 1.0, "e": 0.5},)]
    keys = {cache.key_of("reduced_model", *c) for c in changed}
    assert k0 not in keys and len(keys) == len(changed)
    assert cache.key_of("full_rerun", *base) != k0


def test_a_code_change_is_another_key(monkeypatch):
    k0 = cache.key_of("m", 1)
    monkeypatch.setattr(cache, "CODE_VERSION", "0" * 16)
    assert cache.key_of("m", 1) != k0


@pytest.mark.parametrize("damage", ["truncate", "flip", "garbage", "empty"])
def test_a_damaged_entry_is_ignored_and_rebuilt(folder, damage):
    key = cache.key_of("m", "x")
    p = cache.store(key, _value())
    data = p.read_bytes()
    if damage == "truncate":
        p.write_bytes(data[: len(data) // 2])
    elif damage == "flip":
        p.write_bytes(data[:-10] + bytes([data[-10] ^ 0xFF]) + data[-9:])
    elif damage == "garbage":
        p.write_bytes(b"not a cache entry at all" * 10)
    else:
        p.write_bytes(b"")
    assert cache.load(key) is None and not p.exists()   # a miss, and the bad file is gone
    v, hit = cache.cached("m", ("x",), lambda: _value(1))
    assert not hit and v.x == 1.1 and cache.load(key).x == 1.1


def test_an_entry_under_another_name_is_not_read(folder):
    k1, k2 = cache.key_of("m", 1), cache.key_of("m", 2)
    p1 = cache.store(k1, _value())
    p1.rename(folder / f"{k2}.pkl")     # e.g. a file copied in by hand
    assert cache.load(k2) is None


def test_size_limit_evicts_the_least_recently_used(folder, monkeypatch):
    import os
    import time
    size = len(cache._MAGIC) + 200_000
    monkeypatch.setenv(cache.LIMIT_ENV, str(2.5 * size / 1024 / 1024))   # room for two entries
    keys = [cache.key_of("m", i) for i in range(3)]
    for i, k in enumerate(keys[:2]):
        cache.store(k, np.zeros(25_000) + i)
        t = time.time() - 100 + i
        os.utime(folder / f"{k}.pkl", (t, t))
    assert cache.load(keys[0]) is not None          # a hit makes entry 0 the most recently used
    cache.store(keys[2], np.zeros(25_000) + 2)      # over the limit: entry 1 goes
    left = {p.stem for p in folder.glob("*.pkl")}
    assert left == {keys[0], keys[2]}


def test_an_unwritable_folder_runs_uncached(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    monkeypatch.setenv(cache.CACHE_ENV, str(blocker / "sub"))   # a folder below a file cannot be made
    v, hit = cache.cached("m", (1,), lambda: _value())
    assert not hit and v.x == 0.1


def test_the_correlation_keeps_its_reduced_models(folder, monkeypatch):
    """build_models reads a model back instead of rebuilding it; any change of what it depends on rebuilds."""
    from imutherm.geometry.layout import load_layout
    from imutherm.studies.correlation import models as correlation_models

    calls = []

    def fake_build(variant_fn, grid, knobs, sites, pairs=()):
        calls.append((grid.n_nodes, tuple(k.name for k in knobs)))
        return _value(len(calls))
    monkeypatch.setattr(correlation_models, "build_reduced", fake_build)
    lay = load_layout(None)
    m1 = correlation_models.build_models([("air", 70.0)], lay, mesh_size_mm=6.0, min_cells=1)
    m2 = correlation_models.build_models([("air", 70.0)], lay, mesh_size_mm=6.0, min_cells=1)
    r1, r2 = m1.roms[("air", 70.0)], m2.roms[("air", 70.0)]
    assert len(calls) == 1 and np.array_equal(r1.A, r2.A) and r1.x == r2.x
    # the same content at another path is the same model
    correlation_models.build_models([("air", 70.0)], replace(lay, path="/elsewhere/unit.toml"), mesh_size_mm=6.0,
                                    min_cells=1)
    assert len(calls) == 1
    correlation_models.build_models([("air", 25.0)], lay, mesh_size_mm=6.0, min_cells=1)
    correlation_models.build_models([("air", 70.0)], lay, mesh_size_mm=8.0, min_cells=1)
    correlation_models.build_models([("air", 70.0)], lay, mesh_size_mm=6.0, min_cells=1,
                                    options=ModelOptions(cavity_law="effective"))
    correlation_models.build_models([("air", 70.0)], replace(lay, description=lay.description + " (rev B)"),
                   mesh_size_mm=6.0, min_cells=1)
    assert len(calls) == 5
    correlation_models.build_models([("air", 70.0)], lay, mesh_size_mm=6.0, min_cells=1, use_cache=False)
    assert len(calls) == 6


def test_the_time_constant_precheck_is_kept(folder, monkeypatch):
    """correlate's pre-check (a knobless reduced model per scheme) is read back on the next run of the same
    unit, and a changed input (the ambient) computes it again."""
    from imutherm.geometry.layout import load_layout
    from imutherm.studies.correlation import models as correlation_models

    calls = []
    real = correlation_models.build_reduced

    def counting(*a, **k):
        calls.append(1)
        return real(*a, **k)
    monkeypatch.setattr(correlation_models, "build_reduced", counting)
    lay = load_layout(None)
    first = correlation_models.model_t63_s(lay, "potted", 70.0, ["tp1", "gyro_x"], 14.0, 1, ModelOptions())
    again = correlation_models.model_t63_s(lay, "potted", 70.0, ["tp1", "gyro_x"], 14.0, 1, ModelOptions())
    assert len(calls) == 1 and first == again and 10.0 < first["tp1"] < 1e4
    correlation_models.model_t63_s(lay, "potted", 25.0, ["tp1", "gyro_x"], 14.0, 1, ModelOptions())
    correlation_models.model_t63_s(lay, "potted", 70.0, ["tp1"], 14.0, 1, ModelOptions(), use_cache=False)
    assert len(calls) == 3
