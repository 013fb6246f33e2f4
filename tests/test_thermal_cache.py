"""The end-to-end study's thermal cases kept in the disk cache by their content (issue 59 item 3): a second
study of an unchanged unit solves nothing, a change of a material or of the mesh is another key, a change of
the IMU side alone is the same key; ``--no-cache`` and ``$IMUTHERM_CACHE=off`` turn it off; an entry that
cannot be read is recomputed, said in one line."""

from dataclasses import replace

import numpy as np
import pytest

from imutherm import cache
from imutherm.geometry.layout import load_layout
from imutherm.geometry.materials import get_material
from imutherm.studies.end_to_end import StudyConfig, run_study
from imutherm.studies.end_to_end import run as run_mod
from imutherm.studies.end_to_end import thermal as thermal_mod
from imutherm.unit.model import ModelOptions

#: a coarse mesh, a short power-on, no estimate: a few seconds per thermal case
KW = dict(mesh_size_mm=6.0, min_cells=1, t_end=300.0, transient_model="reduced", until_settled=False)
CONFIG = StudyConfig(seeds=1, profiles=("swing",), filters=("gated",), calibrations=("unit",))


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path / "c"))
    monkeypatch.delenv(cache.ENABLE_ENV, raising=False)
    return tmp_path / "c"


def _no_solve(*args, **kwargs):
    raise AssertionError("a thermal solve was started")


def _study(**kw):
    return run_study(None, ("potted",), config=kw.pop("config", CONFIG), jobs=kw.pop("jobs", 1), **KW, **kw)


def test_a_second_study_solves_nothing(folder, monkeypatch, capsys):
    two = replace(CONFIG, seeds=2)   # two IMU cases: two workers, the thermal case solved and stored in one
    first = _study(config=two, jobs=2)
    assert len(list(folder.glob("*.pkl"))) == 1
    capsys.readouterr()
    for mod, name in ((thermal_mod, "thermal_case"), (thermal_mod, "solve_steady"),
                      ("imutherm.studies.thermal.thermal_study.solve_steady", None),
                      ("imutherm.studies.thermal.thermal_study.solve_transient", None)):
        if name is None:
            monkeypatch.setattr(mod, _no_solve)
        else:
            monkeypatch.setattr(mod, name, _no_solve)
    second = _study()
    out = capsys.readouterr().out
    key = thermal_mod.thermal_key(load_layout(None), "potted", ModelOptions(), CONFIG.chamber_C, **KW)
    assert f"potted: thermal: cached (key {key[:12]})" in out
    a, b = first.schemes["potted"], second.schemes["potted"]
    assert np.array_equal(a.thermal.transient.probe_C, b.thermal.transient.probe_C)
    assert np.array_equal(a.rise_K, b.rise_K) and a.summary == b.summary
    assert b.thermal.geometry.layout.path == load_layout(None).path
    # an IMU-only change (another seed, profile, filter) is the same thermal case: still no solve
    other = replace(CONFIG, seed0=5, profiles=("flight",), filters=("kf",))
    third = _study(config=other)
    assert np.array_equal(third.schemes["potted"].thermal.steady.T_C, a.thermal.steady.T_C)
    assert _study(config=two, jobs=2).schemes["potted"].summary == a.summary   # read in the command, not solved
    # switched off: the study solves again (here: refused by the patched solver)
    with pytest.raises(AssertionError, match="thermal solve"):
        _study(use_cache=False)
    monkeypatch.setenv(cache.ENABLE_ENV, "off")
    with pytest.raises(AssertionError, match="thermal solve"):
        _study()


def _key(layout=None, scheme="potted", options=None, chamber=(-40.0, 70.0), **kw):
    return thermal_mod.thermal_key(layout or load_layout(None), scheme, options or ModelOptions(), chamber,
                                   **{**KW, **kw})


def test_the_key_is_the_content():
    lay = load_layout(None)
    k0 = _key(lay)
    assert k0 == _key(replace(lay, path="/somewhere/else/unit.toml"))   # the content, not the file
    assert k0 == _key(lay, progress=True)
    potting = get_material("potting_compound")
    misses = [_key(lay, mesh_size_mm=5.0), _key(lay, min_cells=2), _key(lay, t_end=400.0),
              _key(lay, estimate_mesh_error=True), _key(lay, transient_model="full"), _key(lay, scheme="grease"),
              _key(lay, chamber=(-20.0, 70.0)), _key(replace(lay, ambient_C=60.0)),
              _key(replace(lay, housing=replace(lay.housing, material="aluminium_6061"))),
              _key(options=ModelOptions(materials=(replace(potting, k_in_plane=potting.k_in_plane * 1.1),))),
              _key(options=ModelOptions(cavity_law="effective"))]
    assert k0 not in misses and len(set(misses)) == len(misses)


def _copies(tmp_path, edit=None):
    """The reference layout, without its ``name`` field (so named after its file), copied into two folders as if
    into two checkouts: a bench CSV beside each copy (its reference data) and the package's paper digest at
    another path for the second (another checkout's); the second's text edited by ``edit`` (old, new) if given.
    Returns the two loaded layouts."""
    import shutil

    from imutherm import reference_data
    from imutherm.geometry.layout_files import default_layout_path

    text = default_layout_path().read_text(encoding="utf-8")
    text = text.replace('paper_figures = "liu2012"', 'paper_figures = "liu2012"\nmeasured = ["bench.csv"]')
    text = text.replace('name = "imu_reference"\n', "", 1)
    out = []
    for i, name in enumerate(("one/unit.toml", "two/checkout/layouts/other_name.toml")):
        f = tmp_path / name
        f.parent.mkdir(parents=True)
        (f.parent / "bench.csv").write_text(f"time_s,tp1_C\n0,{20 + i}\n", encoding="utf-8")
        with pytest.MonkeyPatch.context() as mp:
            if i == 1:
                digest = f.parent / "paper_targets.toml"
                shutil.copy(reference_data.BUILTIN_PAPERS["liu2012"], digest)
                mp.setitem(reference_data.BUILTIN_PAPERS, "liu2012", digest)
                if edit is not None:
                    assert text.count(edit[0]) == 1
                    text = text.replace(*edit)
            f.write_text(text, encoding="utf-8")
            out.append(load_layout(f))
    return out


def test_a_copy_of_the_layout_elsewhere_is_the_same_key(tmp_path):
    """The key is the layout's content: a copy in another folder, under another file name, beside other bench
    files and with the package's digest at another checkout's path is the same key; one number changed is not."""
    a, b = _copies(tmp_path)
    assert a.path != b.path and a.reference_data != b.reference_data and a.name != b.name   # the paths differ ...
    assert _key(a) == _key(b) == _key(load_layout(None))                # ... the key does not
    a, c = _copies(tmp_path / "edited", ("ambient_C = 70.0", "ambient_C = 70.5"))
    assert _key(a) != _key(c)


def test_a_copy_of_the_layout_in_another_checkout_hits_the_cache(folder, tmp_path, monkeypatch, capsys):
    """A study of the copy reads the first copy's thermal case (solves nothing) and carries its own path, name
    and reference data."""
    a, b = _copies(tmp_path)
    first = run_study(a, ("potted",), config=CONFIG, jobs=1, **KW)
    capsys.readouterr()
    monkeypatch.setattr(thermal_mod, "thermal_case", _no_solve)
    second = run_study(b, ("potted",), config=CONFIG, jobs=1, **KW)
    assert f"potted: thermal: cached (key {_key(b)[:12]})" in capsys.readouterr().out
    lay = second.schemes["potted"].thermal.geometry.layout
    assert (lay.path, lay.name, lay.reference_data) == (b.path, b.name, b.reference_data)
    assert np.array_equal(first.schemes["potted"].thermal.steady.T_C, second.schemes["potted"].thermal.steady.T_C)
    _, c = _copies(tmp_path / "edited", ("ambient_C = 70.0", "ambient_C = 70.5"))
    with pytest.raises(AssertionError, match="thermal solve"):
        run_study(c, ("potted",), config=CONFIG, jobs=1, **KW)


def test_the_code_is_in_the_key(monkeypatch):
    k0 = _key()
    monkeypatch.setattr(cache, "CODE_VERSION", "0" * 16)
    assert _key() != k0
    monkeypatch.undo()
    monkeypatch.setattr(thermal_mod, "CASE_SOURCES", thermal_mod.CASE_SOURCES + (("studies", "cost.py"),))
    assert _key() != k0


def test_an_unreadable_entry_is_recomputed_said_in_one_line(folder, capsys):
    key = _key()
    folder.mkdir(parents=True)
    (folder / f"{key}.pkl").write_bytes(b"IMUTHERM-CACHE-1\n" + b"0" * 300)
    keys, found = run_mod._cache_lookup(load_layout(None), ("potted",), ModelOptions(), CONFIG, KW, True)
    assert keys == {"potted": key} and found == {}
    assert capsys.readouterr().out == f"potted: thermal: the cache entry {key[:12]} could not be read: recomputed\n"
    assert not (folder / f"{key}.pkl").exists()


def test_switched_off_reads_nothing(folder, monkeypatch):
    monkeypatch.setattr(cache, "load_status", _no_solve)
    assert run_mod._cache_lookup(load_layout(None), ("potted",), ModelOptions(), CONFIG, KW, False) == \
        ({"potted": None}, {})
    monkeypatch.setenv(cache.ENABLE_ENV, "0")
    assert run_mod._cache_lookup(load_layout(None), ("potted",), ModelOptions(), CONFIG, KW, True)[1] == {}



def test_the_uncertainty_models_are_kept(folder, monkeypatch):
    """``compare --uncertainty``'s reduced models: a second build of the same content reads the first; another
    input range is another key."""
    from imutherm.geometry.build import build_geometry
    from imutherm.studies.uncertainty import uncertainty
    from imutherm.thermal import reduced

    ins = uncertainty.inputs(build_geometry(None, "potted"))
    a = uncertainty.build_scheme_model(None, "potted", ins, mesh_size_mm=6, min_cells=1)
    monkeypatch.setattr(reduced, "build_reduced", _no_solve)
    b = uncertainty.build_scheme_model(load_layout(None), "potted", ins, mesh_size_mm=6, min_cells=1)
    x = uncertainty.knob_values(a, uncertainty.nominal_row(ins))
    assert np.array_equal(a.rom.rise(x, [10.0, np.inf]), b.rom.rise(x, [10.0, np.inf]))
    wider = tuple(replace(i, hi=i.hi * 1.01) if i is ins[0] else i for i in ins)
    with pytest.raises(AssertionError, match="thermal solve"):
        uncertainty.build_scheme_model(None, "potted", wider, mesh_size_mm=6, min_cells=1)
    with pytest.raises(AssertionError, match="thermal solve"):
        uncertainty.build_scheme_model(None, "potted", ins, mesh_size_mm=6, min_cells=1, use_cache=False)


def test_the_thermal_comparison_is_kept(folder, monkeypatch, capsys):
    """``compare --thermal-only``: each scheme's result is read back from the cache, in this process (``jobs``
    1) and in the workers alike."""
    from imutherm.studies.compare import compare_schemes
    from imutherm.studies.thermal import thermal_study

    kw = dict(mesh_size_mm=6.0, min_cells=1, t_end=300.0, transient_model="reduced")
    first = compare_schemes(None, ("potted",), jobs=1, **kw)
    capsys.readouterr()
    monkeypatch.setattr(thermal_study, "run_scheme", _no_solve)
    again = compare_schemes(None, ("potted",), jobs=1, **kw)
    assert "potted: thermal: cached (key " in capsys.readouterr().out
    assert first.summaries == again.summaries
    with pytest.raises(AssertionError, match="thermal solve"):
        compare_schemes(None, ("potted",), jobs=1, use_cache=False, **kw)
    with pytest.raises(AssertionError, match="thermal solve"):
        compare_schemes(None, ("potted",), jobs=1, **{**kw, "mesh_size_mm": 5.0})


def test_a_value_that_does_not_pickle_is_not_stored(folder):
    assert cache.store("0" * 64, lambda: 1) is None and not list(folder.glob("*.pkl"))
    assert cache.cached("m", (1,), lambda: (lambda: 2))[1] is False


def test_a_worker_sends_back_a_lean_case_the_full_one_is_read_back(folder, capsys):
    """Issue 59's memory peak: a worker's thermal case comes back without its thermal problem (per-cell arrays)
    once its cache entry is written; the full value is read back from the cache, or solved again if it is gone."""
    lay, opts = load_layout(None), ModelOptions()
    key = _key()
    lean = thermal_mod.stored_thermal_case(key, lay, "potted", opts, CONFIG.chamber_C, lean=True, **KW)
    assert thermal_mod.is_lean(lean)
    assert lean[0].steady.problem is None and lean[0].transient.problem is None
    full = thermal_mod.full_case(lean, key, lay, "potted", opts, CONFIG.chamber_C, **KW)
    assert not thermal_mod.is_lean(full) and full[0].steady.problem is not None
    assert np.array_equal(full[0].steady.T_C, lean[0].steady.T_C)
    assert np.array_equal(full[0].transient.probe_C, lean[0].transient.probe_C)
    assert np.array_equal(full[1], lean[1]) and np.array_equal(full[2], lean[2])
    assert thermal_mod.full_case(full, key, lay, "potted", opts, CONFIG.chamber_C, **KW) is full
    (folder / f"{key}.pkl").unlink()   # gone meanwhile (evicted): solved again, said in one line
    again = thermal_mod.full_case(lean, key, lay, "potted", opts, CONFIG.chamber_C, **KW)
    assert capsys.readouterr().out == f"potted: thermal: the cache entry {key[:12]} was absent when read back: recomputed\n"
    assert np.array_equal(again[0].steady.T_C, full[0].steady.T_C)
    # not written (no key: the cache off): the full value comes back
    assert not thermal_mod.is_lean(thermal_mod.stored_thermal_case(None, lay, "potted", opts, CONFIG.chamber_C,
                                                                   lean=True, **KW))
