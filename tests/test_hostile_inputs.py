"""A hostile user's corpus: every bad input is refused in one line, early, and no earlier result is touched.

Each refused case runs a subcommand in-process with an earlier ``--out`` (the
files of a real coarse ``imutherm solve``) and asserts: exit status 2, one
error line on stderr naming the file / field / option, no traceback, the
meshing and the studies never started (they are replaced by functions that
fail the test), and ``--out`` byte-identical afterwards (names, contents,
modes). The killed-run tests run ``imutherm solve`` as a subprocess and
SIGKILL / SIGINT it during the computation and at each point of the final
move (``IMUTHERM_TEST_PAUSE``, see :func:`imutherm.cli._common._test_pause`).
"""

from __future__ import annotations

import codecs
import fcntl
import functools
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from imutherm.cli import _common, main

COARSE = ["--mesh-size", "6", "--min-cells", "1"]
#: the cheapest solve (linear: fixed h, no radiation) for the killed-run subprocesses
LINEAR = ["--exterior", "fixed", "--no-radiation", "--no-cavity-radiation"]
REF_TEXT = None  # the reference layout's text, read lazily


def _ref_text() -> str:
    global REF_TEXT
    if REF_TEXT is None:
        from imutherm.geometry.layout import default_layout_path

        REF_TEXT = default_layout_path().read_text()
    return REF_TEXT


def _snapshot(folder: Path) -> dict:
    """name -> (bytes, mode) of everything under ``folder`` (and the folder's own mode)."""
    snap = {".": oct(folder.stat().st_mode)}
    for p in sorted(folder.rglob("*")):
        snap[str(p.relative_to(folder))] = (p.read_bytes() if p.is_file() else None, oct(p.lstat().st_mode))
    return snap


@pytest.fixture(scope="module")
def earlier(tmp_path_factory):
    """A real earlier result set (coarse ``imutherm geometry``) to copy as every test's ``--out``."""
    out = tmp_path_factory.mktemp("earlier") / "out"
    assert main(["geometry", "--scheme", "grease", "--no-png", "--out", str(out)] + COARSE) == 0
    (out / "notes.txt").write_text("the user's own file\n")
    return out


@pytest.fixture
def out(earlier, tmp_path):
    dst = tmp_path / "out"
    shutil.copytree(earlier, dst)
    return dst


def _fail(*args, **kwargs):
    raise AssertionError("work started although the input should have been refused first")


@pytest.fixture
def no_work(monkeypatch):
    """Meshing, solving and the attitude / calibration studies fail the test if they start."""
    import imutherm.cli.calibrate as cal
    import imutherm.cli.geometry as geo
    import imutherm.studies.attitude.attitude_study as att
    import imutherm.studies.thermal.thermal_study as ts

    monkeypatch.setattr(geo, "build_mesh", _fail)
    monkeypatch.setattr(ts, "build_mesh", _fail)
    monkeypatch.setattr(att, "run_attitude_study", _fail)
    monkeypatch.setattr(cal, "run_calibration", _fail)
    try:
        import imutherm.studies.end_to_end as e2e

        monkeypatch.setattr(e2e, "run_study", _fail)
    except ImportError:  # pragma: no cover
        pass


def _run(argv, capsys) -> tuple[int, str]:
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse
        code = exc.code
    err = capsys.readouterr().err
    return code, err


def _assert_refused(code, err, expect):
    assert "Traceback" not in err
    assert code == 2, err
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("usage:") and ln.startswith(" ") is False]
    line = lines[-1]
    assert "error:" in line and len(line) <= _common.MAX_MESSAGE_CHARS + 200, line[:300]
    # one line: only argparse adds its usage lines before it
    assert len(err.strip().splitlines()) == 1 or err.startswith("usage:"), err
    for token in ([expect] if isinstance(expect, str) else expect):
        assert token in line, f"{token!r} not in {line!r}"


# --------------------------------------------------------------------------- layouts that cannot be read
def _bytes_cases() -> dict:
    ref = _ref_text()
    return {
        "random_bytes": (bytes(range(256)) * 20, "not UTF-8"),
        "latin1": (ref.replace('"imu_reference"', '"imu_référence"').encode("latin-1"), "line 23"),
        "utf16_bom": (ref.encode("utf-16"), "UTF-16"),
        "utf16le_no_bom": (ref.encode("utf-16-le"), "NUL"),
        "utf32_bom": (ref.encode("utf-32"), "UTF-32"),
        "nul_byte": (ref.encode()[:500] + b"\0" + ref.encode()[500:], "NUL"),
        "nested_arrays": (b"x = " + b"[" * 100_000 + b"]" * 100_000, "nested too deep"),
        "nested_tables": (b"x = " + b"{a = " * 100_000 + b"1" + b"}" * 100_000, "nested too deep"),
        "oversize": (b"# " + b"x" * (17 * 2**20) + b"\n", "larger than the limit"),
        "empty": (b"", "'environment'"),
        "not_toml": (b"this is not toml\n", "not valid TOML"),
        # cut inside a string (the first board's name), wherever the file's comments put it
        "truncated": (ref.encode()[:ref.encode().index(b'name = "main"') + 10], "not valid TOML"),
        "bom_then_garbage": (codecs.BOM_UTF8 + b"\xff\xfe", "not UTF-8"),
        "many_unknown_keys": (ref.replace("[environment]", "[environment]\n" + "".join(
            f"k{i}_{'x' * 40} = 1\n" for i in range(15_000))).encode(), ["unknown key(s)", "and 14990 more"]),
        "huge_string_value": (ref.replace(
            'default_scheme = "grease"', 'default_scheme = "' + "y" * 900_000 + '"').encode(), "default_scheme"),
        "over_layout_cap": (b"# " + b"x" * 2**20 + b"\n", "1 MiB"),
    }


BYTES_IDS = ["random_bytes", "latin1", "utf16_bom", "utf16le_no_bom", "utf32_bom", "nul_byte", "nested_arrays",
             "nested_tables", "oversize", "over_layout_cap", "empty", "not_toml", "truncated", "bom_then_garbage", "many_unknown_keys",
             "huge_string_value"]


@pytest.mark.parametrize("command", ["geometry", "solve", "compare"])
@pytest.mark.parametrize("case", BYTES_IDS)
def test_unreadable_layout(case, command, out, tmp_path, capsys, no_work):
    data, expect = _bytes_cases()[case]
    layout = tmp_path / f"{case}.toml"
    layout.write_bytes(data)
    before = _snapshot(out)
    progress = [] if command == "geometry" else ["--no-progress"]
    code, err = _run([command, str(layout), "--out", str(out)] + progress + COARSE, capsys)
    _assert_refused(code, err, [str(layout)] + ([expect] if isinstance(expect, str) else expect))
    assert _snapshot(out) == before


@pytest.mark.parametrize("command", ["geometry", "solve"])
@pytest.mark.parametrize("case", ["missing", "directory"])
def test_layout_path_not_a_file(case, command, out, tmp_path, capsys, no_work):
    path = tmp_path / "nope.toml" if case == "missing" else tmp_path
    before = _snapshot(out)
    code, err = _run([command, str(path), "--out", str(out)], capsys)
    _assert_refused(code, err, [str(path), "not found" if case == "missing" else "is a directory"])
    assert _snapshot(out) == before


def test_layout_with_byte_order_mark_is_read(tmp_path):
    from imutherm.geometry.layout import load_layout

    path = tmp_path / "bom.toml"
    path.write_bytes(codecs.BOM_UTF8 + _ref_text().encode())
    assert load_layout(path).name == "imu_reference"


# --------------------------------------------------------------------------- layouts past physical sense
def _set(*keys, value):
    def mutate(d):
        t = d
        for k in keys[:-1]:
            t = t[k]
        t[keys[-1]] = value
    return mutate


PHYSICS = {
    "mounting_minus_400C": (_set("mounting", "temperature_C", value=-400.0), ["[mounting]", "temperature_C"]),
    "mounting_1e6C": (_set("mounting", "temperature_C", value=1e6), ["[mounting]", "temperature_C"]),
    "ambient_1e6C": (_set("environment", "ambient_C", value=1e6), ["[environment]", "ambient_C"]),
    "ambient_minus_300C": (_set("environment", "ambient_C", value=-300.0), ["ambient_C", "-60..150"]),
    "ambient_151C": (_set("environment", "ambient_C", value=151.0), ["ambient_C"]),
    "ambient_nan": (_set("environment", "ambient_C", value=float("nan")), ["ambient_C", "finite"]),
    "ambient_string": (_set("environment", "ambient_C", value="hot"), ["ambient_C", "finite"]),
    "part_power_1e30W": (_set("parts", 0, "power_W", value=1e30), ["standoff", "power_W", "0..100 W"]),
    "part_power_inf": (_set("parts", 0, "power_W", value=float("inf")), ["power_W"]),
    "component_power_1e30W": (_set("components", 0, "power_W", value=1e30), ["'processor'", "power_W"]),
    "component_power_negative": (_set("components", 0, "power_W", value=-1.0), ["'processor'", "power_W"]),
    "housing_10m": (_set("housing", "outer_mm", value=[10000.0, 48.0, 25.0]), ["[housing]", "outer_mm"]),
    "wall_1e-10mm": (_set("housing", "wall_mm", value=1e-10), ["[housing]", "wall_mm", "0.001..1000 mm"]),
    "standoff_1e-10mm": (_set("parts", 0, "size_mm", value=[3.0, 3.0, 1e-10]), ["part 'standoff_1'", "size_mm"]),
    "die_1e-12mm": (_set("components", 0, "die_mm", value=[6.0, 6.0, 1e-12]), ["'processor'", "die_mm"]),
    "board_1e-9mm": (_set("boards", 0, "size_mm", value=[66.0, 44.0, 1e-9]), ["board 'main'", "size_mm"]),
    "corner_1e9mm": (_set("parts", 0, "min_mm", value=[1e9, 4.5, 3.0]), ["part 'standoff_1'", "min_mm"]),
    "contact_1e12": (_set("mounting", "contact_conductance_W_m2K", value=1e12), ["contact_conductance_W_m2K"]),
    "bond_gap_1e9mm": (_set("schemes", "grease", "max_bond_gap_mm", value=1e9), ["'grease'", "max_bond_gap_mm"]),
    "pad_zero": (_set("components", 0, "pad_mm", value=[0.0, 6.0]), ["'processor'", "pad_mm"]),
}


@pytest.mark.parametrize("command", ["geometry", "solve"])
@pytest.mark.parametrize("case", list(PHYSICS))
def test_layout_past_physical_sense(case, command, out, write_layout, capsys, no_work):
    mutate, expect = PHYSICS[case]
    layout = write_layout(mutate)
    before = _snapshot(out)
    code, err = _run([command, str(layout), "--out", str(out)] + COARSE, capsys)
    _assert_refused(code, err, [str(layout)] + expect)
    assert _snapshot(out) == before


# --------------------------------------------------------------------------- options nobody can afford / nonsense
OPTIONS = {
    "mesh_0.01": (["solve", "--mesh-size", "0.01"], ["estimated", "cells", "--mesh-size"]),
    "mesh_0.1": (["solve", "--mesh-size", "0.1"], ["estimated", "GiB"]),
    "mesh_tiny": (["geometry", "--mesh-size", "1e-300"], ["estimated", "cells"]),
    "mesh_negative": (["geometry", "--mesh-size", "-1"], "--mesh-size"),
    "mesh_nan": (["solve", "--mesh-size", "nan"], "--mesh-size"),
    "mesh_inf": (["solve", "--mesh-size", "inf"], "--mesh-size"),
    "min_cells_1000": (["solve", "--min-cells", "1000"], ["estimated", "--min-cells"]),
    "min_cells_0": (["geometry", "--min-cells", "0"], "--min-cells"),
    "min_cells_negative": (["solve", "--min-cells", "-3"], "--min-cells"),
    "max_memory_small": (["solve", "--max-memory", "50M"], ["estimated", "--max-memory"]),
    "max_memory_geometry": (["geometry", "--max-memory", "1M"], ["estimated", "--max-memory"]),
    "max_memory_garbage": (["solve", "--max-memory", "lots"], "--max-memory"),
    "max_memory_zero": (["geometry", "--max-memory", "0"], "--max-memory"),
    "t_end_1e13": (["solve", "--transient", "--t-end", "1e13", "--dt", "1"], ["time steps", "--t-end"]),
    "t_end_1e13_adaptive": (["solve", "--transient", "--t-end", "1e13"], ["time steps", "--t-end"]),
    "t_end_1e9_dt_1e-3": (["solve", "--transient", "--t-end", "1e9", "--dt", "1e-3"], ["time steps"]),
    "constant_tiny_steps": (["solve", "--transient", "--dt", "1e-4", "--dt-max", "1e-4"], ["time steps"]),
    "save_every_1e-9": (["solve", "--transient", "--save-every", "1e-9"], "--save-every"),
    "save_every_zero": (["solve", "--transient", "--save-every", "0"], "--save-every"),
    "theta_2": (["solve", "--transient", "--theta", "2"], "--theta"),
    "dt_zero": (["solve", "--transient", "--dt", "0"], "dt"),
    "dt_nan": (["solve", "--transient", "--dt", "nan"], "dt"),
    "unknown_site": (["solve", "--site", "nowhere"], "--site"),
    "unknown_scheme": (["solve", "--scheme", "ice"], "ice"),
    "emissivity_2": (["solve", "--emissivity", "2"], "emissivity"),
    "h_negative": (["solve", "--exterior", "fixed", "--h", "-5"], "h_fixed_W_m2K"),
    "compare_schemes_comma": (["compare", "--schemes", ","], "--schemes"),
    "compare_schemes_blank": (["compare", "--schemes", " "], "--schemes"),
    "compare_unknown_scheme": (["compare", "--schemes", "air,ice"], "ice"),
    "compare_t_end_1e13": (["compare", "--t-end", "1e13", "--dt", "1"], ["time steps"]),
    "compare_mesh_0.2": (["compare", "--mesh-size", "0.2"], ["estimated", "cells"]),
    "compare_memory": (["compare", "--max-memory", "100M"], ["estimated", "--max-memory"]),
    "compare_seed_negative": (["compare", "--seed", "-1"], "--seed"),
    "compare_seeds_0": (["compare", "--seeds", "0"], "--seeds"),
    "compare_seeds_1000_imu_time": (["compare", "--seeds", "1000"], ["IMU side", "3,000 cases", "h on 1 worker",
                                                                      "limit of 6 h", "--seeds"]),
    "compare_jobs_memory_limit": (["compare", "--jobs", "9", "--max-memory", "1G", "--no-mesh-error"],
                                  ["IMU side", "8 worker", "--max-memory"]),
    "compare_mesh_error_memory": (["compare", "--max-memory", "1G"], ["mesh-error estimate", "--no-mesh-error"]),
    "compare_schemes_side_by_side_memory": (["compare", "--thermal-only", "--max-memory", "1.5G"],
                                            ["2 schemes solved side by side", "--jobs 1", "--no-mesh-error"]),
    "compare_jobs_0": (["compare", "--jobs", "0"], "--jobs"),
    "compare_steady_only_t_end": (["compare", "--steady-only", "--t-end", "600", "--full-length"],
                                  ["--t-end, --full-length", "with --steady-only"]),
    "solve_steady_dt": (["solve", "--dt", "5", "--dt-max", "60"], ["--dt, --dt-max", "without --transient"]),
    "attitude_duration_1e9": (["attitude", "--profile", "flight", "--duration", "1e9"], ["--duration", "samples"]),
    "attitude_seeds_1e9": (["attitude", "--profile", "flight", "--seeds", "1000000000"], ["--seeds", "samples"]),
    "attitude_seeds_0": (["attitude", "--profile", "flight", "--seeds", "0"], "--seeds"),
    "attitude_seed0_negative": (["attitude", "--profile", "flight", "--seed0", "-1"], "--seed0"),
    "attitude_seed_ambiguous": (["attitude", "--profile", "flight", "--seed", "-1"], "--seed"),
    "attitude_duration_negative": (["attitude", "--profile", "flight", "--duration", "-5"], "--duration"),
    "attitude_duration_nan": (["attitude", "--profile", "flight", "--duration", "nan"], "--duration"),
    "attitude_memory": (["attitude", "--profile", "flight", "--duration", "3e5", "--max-memory", "1G"],
                        ["--duration", "--max-memory"]),
    "attitude_unknown_grade": (["attitude", "--profile", "flight", "--grade", "nope"], "nope"),
    "attitude_unknown_profile": (["attitude", "--profile", "loop"], "loop"),
    "calibrate_seed_negative": (["calibrate", "--seed", "-1"], "--seed"),
    "calibrate_unknown_grade": (["calibrate", "--grade", "nope"], "nope"),
}


@pytest.mark.parametrize("case", list(OPTIONS))
def test_bad_option(case, out, capsys, no_work):
    argv, expect = OPTIONS[case]
    before = _snapshot(out)
    code, err = _run(argv + ["--out", str(out)], capsys)
    _assert_refused(code, err, expect)
    assert _snapshot(out) == before


# --------------------------------------------------------------------------- temperature CSVs
def _csv_cases() -> dict:
    good = "time_s,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z\n0,25,25,25,25,25,25\n10,26,26,26,26,26,26\n"
    return {
        "random_bytes": (bytes(range(256)) * 4, "not UTF-8"),
        "latin1": (("# température\n" + good).encode("latin-1"), "line 1"),
        "utf16": (good.encode("utf-16"), "UTF-16"),
        "nul": (good.encode().replace(b"10,", b"1\0,"), "NUL"),
        "oversize": (b"#" * (17 * 2**20), "larger than the limit"),
        "huge_field": (('"' + "x" * 200_000 + '"\n' + good).encode(), "not a valid CSV"),
        "missing_column": (good.replace("accel_z", "accel_q").encode(), "'accel_z'"),
        "text_value": (good.replace("26,26,26\n", "26,26,hot\n").encode(), "non-numeric"),
        "header_only": (good.splitlines()[0].encode(), "header"),
        "time_backwards": (good.replace("\n10,", "\n-10,").encode(), "strictly increasing"),
        "too_hot": (good.replace("26", "900").encode(), "calibrated range"),
    }


@pytest.mark.parametrize("case", list(_csv_cases()))
def test_bad_temperature_csv(case, out, tmp_path, capsys, monkeypatch):
    import imutherm.studies.attitude.attitude_study as att

    data, expect = _csv_cases()[case]
    path = tmp_path / f"{case}.csv"
    path.write_bytes(data)
    # the study runs up to the temperature lookup; the motion profile is the short static one
    before = _snapshot(out)
    code, err = _run(["attitude", "--profile", "static", "--duration", "5", "--temperature-csv", str(path),
                      "--out", str(out), "--no-plot"], capsys)
    _assert_refused(code, err, ["temperature", expect])
    assert str(path) in err or case == "too_hot"
    assert _snapshot(out) == before


def test_temperature_csv_with_byte_order_mark(tmp_path):
    from imutherm.studies.attitude.attitude_study import read_temperature_csv

    path = tmp_path / "bom.csv"
    path.write_bytes(codecs.BOM_UTF8 + b"time_s,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z\n0,1,2,3,4,5,6\n")
    t, T = read_temperature_csv(path)
    assert t.tolist() == [0.0] and T.tolist() == [[1, 2, 3, 4, 5, 6]]


# --------------------------------------------------------------------------- --out itself
def _out_cases(tmp_path: Path) -> dict:
    afile = tmp_path / "afile"
    afile.write_text("x")
    return {
        "empty": ("", "--out is empty"),
        "blank": ("   ", "--out is empty"),
        "under_proc": ("/proc/imutherm_out", ["--out /proc/imutherm_out", "cannot write"]),
        "under_sys": ("/sys/imutherm/out", ["--out /sys/imutherm/out", "cannot write"]),
        "is_a_file": (str(afile), ["--out", "not a directory"]),
        "under_a_file": (str(afile / "sub"), ["--out", "not a directory"]),
    }


@pytest.mark.parametrize("command", ["geometry", "solve", "compare", "attitude", "calibrate", "verify"])
@pytest.mark.parametrize("case", ["empty", "blank", "under_proc", "under_sys", "is_a_file", "under_a_file"])
def test_bad_out(case, command, tmp_path, capsys, no_work, monkeypatch):
    import imutherm.thermal.verification as ver

    monkeypatch.setattr(ver, "run_all", _fail)  # verify's suite must not start either
    value, expect = _out_cases(tmp_path)[case]
    extra = ["--profile", "flight"] if command == "attitude" else []
    before = _snapshot(tmp_path)
    code, err = _run([command] + extra + ["--out", value], capsys)
    _assert_refused(code, err, expect)
    assert _snapshot(tmp_path) == before


def test_two_runs_into_one_out_refuse(out, capsys, no_work):
    """A second run into an --out another run holds is refused before any work (the lock is an flock)."""
    real = Path(os.path.realpath(out))
    path = _common._lock_path(real)
    with open(path, "a+") as fh:  # what the other run's check_outdir holds
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        fh.write("4242\n")
        fh.flush()
        before = _snapshot(out)
        code, err = _run(["solve", "--out", str(out)] + COARSE, capsys)
        _assert_refused(code, err, ["--out", "another imutherm run", "4242"])
        assert _snapshot(out) == before


def test_lock_is_released_after_a_run(out, capsys):
    code, _ = _run(["geometry", "--no-png", "--out", str(out)] + COARSE, capsys)
    assert code == 0 and not _common._LOCKS
    path = _common._lock_path(Path(os.path.realpath(out)))
    assert not path.exists()  # removed at the end, so lock files do not pile up
    with open(path, "a+") as fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)  # free again


# --------------------------------------------------------------------------- atomic output, in-process
def test_symlinked_out_on_another_file_system(tmp_path, capsys):
    """--out a symlink to another file system: the target is replaced whole, old field files go only
    with the new set in place, the link stays, modes are 0644/0755 (umask 022)."""
    shm = Path("/dev/shm")
    if not shm.is_dir() or os.stat(shm).st_dev == os.stat(tmp_path).st_dev:
        pytest.skip("needs /dev/shm on another file system")
    target = Path(tempfile_mkdtemp(shm)) / "results"
    try:
        target.mkdir()
        for name in ("field.pvd", "field_0000.vtu", "field_0012.vtu", "notes.txt"):
            (target / name).write_text("old")
        link = tmp_path / "out"
        link.symlink_to(target)
        old_umask = os.umask(0o022)
        try:
            with _common.atomic_outdir(link, stale=_common.FIELD_FILES) as tmp:
                assert os.stat(tmp).st_dev == os.stat(target).st_dev  # beside the resolved --out
                for name in ("field.vtu", "probes.csv", "result.json"):
                    (tmp / name).write_text("new")
                os.chmod(tmp / "field.vtu", 0o600)  # as meshio leaves it
        finally:
            os.umask(old_umask)
        assert link.is_symlink()
        names = sorted(os.listdir(target))
        assert names == ["field.vtu", "notes.txt", "probes.csv", "result.json"]
        assert (target / "notes.txt").read_text() == "old"
        assert {oct(os.stat(target / n).st_mode & 0o777) for n in names} == {"0o644"}
        assert not [p for p in target.parent.iterdir() if p.name != "results"]
    finally:
        shutil.rmtree(target.parent, ignore_errors=True)


def tempfile_mkdtemp(where: Path) -> str:
    import tempfile

    return tempfile.mkdtemp(dir=where)


def test_failed_run_leaves_out_untouched(out):
    before = _snapshot(out)
    with pytest.raises(RuntimeError):
        with _common.atomic_outdir(out, stale=_common.FIELD_FILES) as tmp:
            (tmp / "field.pvd").write_text("new")
            raise RuntimeError("failed")
    assert _snapshot(out) == before
    assert [p.name for p in out.parent.iterdir()] == ["out"]


def test_without_exchange_a_kill_between_the_renames_is_recovered(out, monkeypatch):
    """Where renameat2(RENAME_EXCHANGE) is unavailable: killed between 'out -> backup' and 'new -> out',
    the next run into out puts the backup (the complete earlier set) back before anything else."""

    class Killed(BaseException):
        pass

    def pause(stage):
        if stage == "old-moved":
            raise Killed

    before = _snapshot(out)
    monkeypatch.setattr(_common, "_exchange", lambda a, b: False)
    monkeypatch.setattr(_common, "_test_pause", pause)
    with pytest.raises(Killed):
        with _common.atomic_outdir(out) as tmp:
            (tmp / "result.json").write_text("{}")
    assert not out.exists()
    backups = [p for p in out.parent.iterdir() if ".imutherm-old-" in p.name]
    assert len(backups) == 1 and _snapshot(backups[0]) == before
    monkeypatch.setattr(_common, "_test_pause", lambda stage: None)
    with pytest.raises(RuntimeError):  # the next run, failing itself, still restores the earlier set first
        with _common.atomic_outdir(out):
            raise RuntimeError("failed")
    assert _snapshot(out) == before
    assert [p.name for p in out.parent.iterdir()] == ["out"]


def test_working_directory_as_out_is_updated_file_by_file(tmp_path, monkeypatch):
    """--out . (the working directory) is never swapped away: files are replaced one by one."""
    (tmp_path / "field_0007.vtu").write_text("old")
    (tmp_path / "keep.txt").write_text("keep")
    monkeypatch.chdir(tmp_path)
    with _common.atomic_outdir(".", stale=_common.FIELD_FILES) as tmp:
        (tmp / "field.vtu").write_text("new")
    assert sorted(os.listdir(tmp_path)) == ["field.vtu", "keep.txt"]
    assert Path.cwd() == tmp_path


# --------------------------------------------------------------------------- killed runs (subprocesses)
def _default_sigint():
    """In the child before exec: the default SIGINT handler. A test run started as a background job of a
    non-interactive shell has SIGINT ignored, and children inherit that (the commands keep honouring an
    inherited ignore, as programs conventionally do); the tests send SIGINT and expect Ctrl-C's handling."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _spawn(out: Path, pause: str | None = None, extra=(), sigint=_default_sigint):
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    if pause:
        env.update(IMUTHERM_TEST_PAUSE=pause, IMUTHERM_TEST_PAUSE_S="60")
    code = "import sys; from imutherm.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.Popen([sys.executable, "-c", code, "solve", "--scheme", "grease", "--out", str(out),
                             *extra, *COARSE, *LINEAR], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            preexec_fn=sigint)


def _wait_for_pause(proc, stage):
    deadline = time.monotonic() + 300
    for line in proc.stderr:
        if f"test pause at {stage}" in line:
            return
        if time.monotonic() > deadline:
            break
    proc.kill()
    raise AssertionError(f"the run never reached {stage}")


def _complete_new_set(out: Path, before: dict):
    """The solve's files are all there and complete; the earlier files it does not write are carried over."""
    import json

    names = set(os.listdir(out))
    assert {"field.vtu", "probes.csv", "result.json"} <= names
    assert json.loads((out / "result.json").read_text())["scheme"] == "grease"
    assert (out / "field.vtu").read_bytes().rstrip().endswith(b"</VTKFile>")
    carried = {k for k in before if k != "." and "/" not in k} - {"field.vtu", "probes.csv", "result.json"}
    assert names == carried | {"field.vtu", "probes.csv", "result.json"}
    assert all((out / k).read_bytes() == before[k][0] for k in carried)


@pytest.mark.parametrize("stage, sig", [("written", signal.SIGKILL), ("swap", signal.SIGKILL),
                                        ("swapped", signal.SIGKILL), ("swap", signal.SIGINT),
                                        ("written", signal.SIGINT), ("swapped", signal.SIGINT)])
def test_killed_during_the_final_move(stage, sig, out, capsys):
    """Killed just after writing, just before the exchange, just after it: out holds the complete old
    or the complete new set; the next run cleans up what the killed one left beside it."""
    before = _snapshot(out)
    proc = _spawn(out, stage)
    _wait_for_pause(proc, stage)
    if stage == "written":  # meanwhile a second run into the same --out is refused at once
        second = _spawn(out)
        _, err = second.communicate(timeout=120)
        assert second.returncode == 2 and "another imutherm run" in err and f"pid {proc.pid}" in err, err
        assert "Traceback" not in err
    proc.send_signal(sig)
    proc.wait(timeout=60)
    if sig == signal.SIGINT:
        assert proc.returncode == 130
    if stage == "swapped":
        _complete_new_set(out, before)  # the exchange happened: the new set is complete
    else:
        assert _snapshot(out) == before
    if sig == signal.SIGINT:  # Ctrl-C cleans up after itself
        assert [p.name for p in out.parent.iterdir()] == ["out"]
    # the next run into out (a cheap one) removes what the killed run left beside it
    code, err = _run(["geometry", "--no-png", "--out", str(out)] + COARSE, capsys)
    assert code == 0, err
    assert [p.name for p in out.parent.iterdir()] == ["out"]


@pytest.fixture(scope="module")
def uncut_run_s(earlier, tmp_path_factory):
    """Wall time [s] of one uncut killed-run subprocess (launch to exit), here and now (the machine's load)."""
    dst = tmp_path_factory.mktemp("uncut") / "out"
    shutil.copytree(earlier, dst)
    start = time.monotonic()
    proc = _spawn(dst)
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    return time.monotonic() - start


@pytest.mark.parametrize("seed", [0, 1] + [pytest.param(k, marks=pytest.mark.slow) for k in range(2, 12)])
def test_killed_at_a_random_point(seed, uncut_run_s, out, capsys):
    """SIGKILL (even seeds) or SIGINT (odd) at a time drawn uniformly over an uncut run's length (start-up,
    meshing, solve, writing, the final move): ``out`` is then byte-identical to the earlier set or holds the
    complete new one, never a mix; the next run into it leaves nothing beside it."""
    import numpy as np

    rng = np.random.default_rng(seed)
    sig = signal.SIGINT if seed % 2 else signal.SIGKILL
    delay = float(rng.uniform(0.0, 1.05 * uncut_run_s))
    before = _snapshot(out)
    proc = _spawn(out)
    time.sleep(delay)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0 or _snapshot(out) != before:  # finished, or killed after the exchange
        _complete_new_set(out, before)
    if sig == signal.SIGINT and proc.returncode == 130:  # interrupted inside the command: one line, tidied up
        assert err.strip().splitlines()[-1] == "imutherm solve: interrupted" and "Traceback" not in err
        assert [p.name for p in out.parent.iterdir()] == ["out"]
    code, err = _run(["geometry", "--no-png", "--out", str(out)] + COARSE, capsys)
    assert code == 0, err
    assert [p.name for p in out.parent.iterdir()] == ["out"]


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT])
def test_killed_during_the_computation(sig, out):
    """A signal while ``solve`` computes (held at the test pause before the solve, checks done, nothing written
    yet; deterministic on a machine of any speed): ``out`` stays byte-identical, nothing is left beside it."""
    before = _snapshot(out)
    proc = _spawn(out, pause="solving")
    _wait_for_pause(proc, "solving")
    proc.send_signal(sig)
    proc.communicate(timeout=60)
    assert proc.returncode != 0
    assert _snapshot(out) == before
    assert [p.name for p in out.parent.iterdir()] == ["out"]


# --------------------------------------------------------------------------- divergence is not a hang
@pytest.mark.parametrize("nonlinear", [True, False])
def test_steady_divergence_names_the_power(nonlinear):
    """1e30 W/m^3 (past the layout check, straight into the solver): a ConvergenceError at the first
    iterate naming the total power, not 50 overflowing Newton iterations."""
    import warnings

    import numpy as np

    from imutherm.geometry.grid import TensorGrid
    from imutherm.thermal.problem import Convection, Radiation, ThermalProblem
    from imutherm.thermal.solve import ConvergenceError, solve_steady

    xs = np.linspace(0.0, 0.01, 5)
    grid = TensorGrid(xs, xs, xs, np.zeros((4, 4, 4), np.int32), ("box",), {})
    laws = (Radiation(0.8), Convection(10.0)) if nonlinear else (Convection(10.0),)
    faces = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")
    sane = ThermalProblem(grid, 200.0, 2.4e6, 1e6, 20.0, {f: laws for f in faces})  # 1 W: solves
    assert np.isfinite(solve_steady(sane).T_C).all()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(ConvergenceError, match=r"diverging at Newton iteration 1 .*total 1e\+24 W"):
            solve_steady(ThermalProblem(grid, 200.0, 2.4e6, 1e30, 20.0, {f: laws for f in faces}))


def test_study_cost_counts_the_imu_work():
    """The compare estimate counts what imu_case runs: per (scheme, seed) every profile's samples in both
    phases, for the uncompensated set and each calibration x compensation, through every filter."""
    from imutherm.studies.cost import SECONDS_PER_CASE, SECONDS_PER_FILTER_SAMPLE, check_study_cost
    from imutherm.studies.end_to_end import StudyConfig

    w = check_study_cost(StudyConfig(), 3, 2, 1e15)
    assert w["samples"] == {"flight": 40_000, "swing": 6_000}   # 400 s and 60 s at 100 Hz
    nf = len(StudyConfig().filters)  # gated, kf, ungated, fusion, vqf
    assert (w["sets"], w["cases"]) == (5, 9) and w["filter_samples"] == 9 * 46_000 * 2 * 5 * nf
    assert w["seconds"] == pytest.approx(9 * 46_000 * 2 * 5 * nf * SECONDS_PER_FILTER_SAMPLE + 9 * SECONDS_PER_CASE)
    lean = check_study_cost(StudyConfig(seeds=1, profiles=("swing",), compensations=("improved",),
                                        filters=("gated",), calibrations=("unit",)), 1, 1, 1e15)
    assert (lean["sets"], lean["filter_samples"]) == (1, 6_000 * 2)
    two = check_study_cost(StudyConfig(), 3, 3, 1e15)          # two workers share the cases (given two CPUs)
    assert two["seconds"] == pytest.approx(w["seconds"] / min(2, os.cpu_count() or 1))
    assert two["memory_bytes"] > w["memory_bytes"]


# ------------------------------------- the newer commands: refused before the costly work, no option reinterpreted
@pytest.fixture
def no_expensive(no_work, monkeypatch):
    """Besides :func:`no_work`: the s2s view factors, the sweep's cases, correlate's reduced models and its
    time-constant pre-check fail the test if they start (the refusal must come before them)."""
    import imutherm.studies.correlation.models as corr_models
    import imutherm.studies.correlation.workflow as corr_workflow
    import imutherm.studies.sweep.run as sw
    import imutherm.thermal.cavity_radiation as cr

    monkeypatch.setattr(cr, "view_factors", _fail)
    monkeypatch.setattr(sw, "run_case", _fail)
    monkeypatch.setattr(corr_workflow, "build_models", _fail)
    monkeypatch.setattr(corr_models, "model_t63_s", _fail)


TEMPS = "time_s,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z\n"
MEASURED = {  # name -> (text, expected tokens)
    "kelvin": ("# scheme = air\n# ambient_C = 70\ntime_s,tp1\n300,358.1\ninf,363.15\n", ["kelvin", "ambient_C"]),
    "kelvin_power_on": ("# scheme = air\n# ambient_C = 70\ntime_s,tp1\n0,343.15\n300,358.1\n", ["kelvin", "power-on"]),
    "fahrenheit": ("# scheme = air\n# ambient_C = 70\ntime_s,tp1\n0,158\n300,190\n", ["degF", "power-on"]),
    "one_row": ("# scheme = air\n# ambient_C = 70\ntime_s,tp1\n0,70\n", ["one row"]),
    # readings no unit of this kind can produce (studies/correlation/plausibility.py), refused before any model is built
    "rise_300K": ("# scheme = air\n# ambient_C = 70\ntime_s,tp1\n0,70\n300,90\n600,370.5\ninf,95\n",
                  ["370.5", "solder"]),
    "colder_than_ambient": ("# scheme = air\n# ambient_C = 70\ntime_s,tp1\n0,70\n300,90\n600,61\ninf,95\n",
                            ["below the ambient", "under power"]),
}
REFUSED_EARLY = {  # name -> (argv without --out, expected tokens); files from _refusal_files
    "s2s_patches_solve": (["solve", "--cavity-law", "s2s", "--cavity-patch-mm", "0.001", "--max-memory", "2G"],
                          ["cavity patches", "--cavity-patch-mm"]),
    "s2s_patches_compare": (["compare", "--thermal-only", "--cavity-law", "s2s", "--cavity-patch-mm", "0.001",
                             "--max-memory", "2G"], ["cavity patches", "--cavity-patch-mm"]),
    "s2s_patches_sweep": (["sweep", "--set", "environment.ambient_C=20,30", "--cavity-law", "s2s",
                           "--cavity-patch-mm", "0.001", "--max-memory", "2G"], ["cavity patches"]),
    "s2s_patches_correlate": (["correlate", "--measured", "{paper_air}", "--cavity-law", "s2s",
                               "--cavity-patch-mm", "0.001", "--max-memory", "2G"], ["cavity patches"]),
    "sweep_1000x1000": (["sweep", "--set", "environment.ambient_C=20:60:1000", "--set",
                         "mounting.temperature_C=20:60:1000"], ["1,000,000 cases", "limit"]),
    "sweep_cpu_hours": (["sweep", "--set", "environment.ambient_C=20:60:300", "--set", "mounting.temperature_C=20:60:300",
                         "--mesh-size", "2"], ["90,000 cases", "--max-cpu-hours"]),
    "sweep_memory_jobs": (["sweep", "--set", "environment.ambient_C=20,30", "--jobs", "2", "--max-memory", "150M"],
                          ["worker", "--max-memory"]),
    "correlate_holdout_unknown": (["correlate", "--measured", "{paper_air}", "--holdout", "nope.csv"], ["--holdout"]),
    "correlate_build_memory": (["correlate", "--measured", "{paper_air}", "{paper_grease}", "--jobs", "2",
                                "--max-memory", "1G", "--mesh-size", "2"], ["reduced model", "--max-memory"]),
    "effect_repeated_key": (["solve", "--effect", "contact@bond:h_W_m2K=300,h_W_m2K=5000"], ["given twice"]),
    "attitude_csv_late": (["attitude", "--profile", "static", "--duration", "20", "--temperature-csv", "{late}"],
                          ["1e+06..2e+06", "do not cover"]),
    "attitude_csv_negative": (["attitude", "--profile", "static", "--duration", "20", "--temperature-csv", "{negative}"],
                              ["-100..-1", "do not cover"]),
    # options the combination would ignore (cli/_ignored.py): one case per row of the table
    "ignored_solve_time": (["solve", "--t-end", "600"], ["--t-end", "without --transient"]),
    "ignored_compare_time": (["compare", "--steady-only", "--dt", "5"], ["--dt", "with --steady-only"]),
    "ignored_compare_imu": (["compare", "--thermal-only", "--seeds", "2"], ["--seeds", "--thermal-only"]),
    "ignored_signal_effect": (["solve", "--effect", "probe_lag:tau_s=30"], ["--effect", "without --transient"]),
    "ignored_sweep_t_end": (["sweep", "--set", "environment.ambient_C=20,30", "--t-end", "100"], ["--t-end"]),
    "ignored_sweep_attitude_seeds": (["sweep", "--set", "environment.ambient_C=20,30", "--attitude-seeds", "2"],
                                     ["--attitude-seeds", "without --attitude"]),
    "ignored_patch_no_cavity": (["solve", "--cavity-patch-mm", "2", "--no-cavity-radiation"],
                                ["--cavity-patch-mm", "--no-cavity-radiation"]),
    "ignored_full_without_rerun": (["correlate", "--measured", "{paper_air}", "--no-rerun", "--full"],
                                   ["--full", "with --no-rerun"]),
    "ignored_patch_without_s2s": (["correlate", "--measured", "{paper_air}", "--cavity-law", "effective",
                                   "--cavity-patch-mm", "2"], ["--cavity-patch-mm", "without --cavity-law s2s"]),
    "ignored_uncertainty_size": (["compare", "--uncertainty-samples", "64"], ["--uncertainty-samples",
                                                                               "without --uncertainty"]),
    "ignored_uncertainty_imu_thermal": (["compare", "--thermal-only", "--uncertainty", "--uncertainty-imu-draws", "4"],
                                        ["--uncertainty-imu-draws", "with --thermal-only", "no IMU chain"]),
    "ignored_filter_defaults": (["compare", "--thermal-only", "--filter-defaults"], ["--filter-defaults"]),
    "ignored_verify_full_fem": (["sweep", "--set", "environment.ambient_C=20,30", "--surrogate", "none", "--verify",
                                 "3"], ["--verify", "--surrogate none"]),
    "ignored_h": (["sweep", "--set", "environment.ambient_C=20,30", "--h", "5"], ["--h", "--exterior fixed"]),
    "ignored_emissivity": (["compare", "--emissivity", "0.5", "--no-radiation"], ["--emissivity", "--no-radiation"]),
    "ignored_load_dependence": (["calibrate", "--load-dependence"], ["--load-dependence", "--procedure overload"]),
    "ignored_rig_options": (["calibrate", "--procedure", "roll-coupling", "--interp", "segment"], ["--interp"]),
    "ignored_profile_options": (["attitude", "--imu-csv", "{late}", "--duration", "5"], ["--duration", "--imu-csv"]),
    "ignored_log_options": (["attitude", "--profile", "static", "--platform", "vehicle"],
                            ["--platform", "without --imu-csv"]),
    **{f"measured_{k}": (["correlate", "--measured", f"{{{k}}}"], v[1]) for k, v in MEASURED.items()},
}


def _refusal_files(tmp_path: Path) -> dict:
    ex = Path(__file__).resolve().parents[1] / "examples" / "measured"
    files = {"paper_air": str(ex / "paper_000_air.csv"), "paper_grease": str(ex / "paper_000_grease.csv")}
    for name, (text, _) in MEASURED.items():
        (tmp_path / f"{name}.csv").write_text(text)
        files[name] = str(tmp_path / f"{name}.csv")
    (tmp_path / "late.csv").write_text(TEMPS + "1e6,25,25,25,25,25,25\n2e6,26,26,26,26,26,26\n")
    (tmp_path / "negative.csv").write_text(TEMPS + "-100,25,25,25,25,25,25\n-1,26,26,26,26,26,26\n")
    files.update(late=str(tmp_path / "late.csv"), negative=str(tmp_path / "negative.csv"))
    return files


@pytest.mark.parametrize("case", list(REFUSED_EARLY))
def test_refused_before_the_work(case, out, tmp_path, capsys, no_expensive):
    """Each refusal class of the newer commands' options: one line, exit 2, ``--out`` untouched, and none of
    the expensive steps (meshing for the solve, the s2s view factors, the sweep's cases, the reduced models,
    the studies) started."""
    files = _refusal_files(tmp_path)
    argv, expect = REFUSED_EARLY[case]
    argv = [a.format(**files) for a in argv]
    coarse = [] if "--mesh-size" in argv or argv[0] in ("calibrate", "attitude") else COARSE
    before = _snapshot(out)
    code, err = _run(argv + coarse + ["--out", str(out)], capsys)
    _assert_refused(code, err, expect)
    assert _snapshot(out) == before


def test_correlate_short_file_refused_before_the_build(out, tmp_path, capsys, no_expensive, monkeypatch):
    """A file ending before its sites' t63 is refused by the pre-check (a knobless reduced model, here
    replaced by its answer) before the reduced models are built (build_models fails the test)."""
    import imutherm.studies.correlation.models as corr

    seen = []

    def t63(layout, scheme, amb, sites, mesh, min_cells, options, use_cache=True):
        seen.append((scheme, amb, mesh))
        return {s: 100.0 for s in sites}

    monkeypatch.setattr(corr, "model_t63_s", t63)
    short = tmp_path / "short.csv"
    short.write_text("# scheme = grease\n# ambient_C = 70\ntime_s,tp1,gyro_x\n0,70,70\n10,72,70.5\n20,73,71\n")
    before = _snapshot(out)
    code, err = _run(["correlate", "--measured", str(short), "--out", str(out)] + COARSE, capsys)
    _assert_refused(code, err, [f"{short}:6", "ends at 20 s", "~100 s"])
    assert seen == [("grease", 70.0, corr.PRECHECK_MESH_MM)] and _snapshot(out) == before


def test_s2s_default_patches_pass_the_cost_model_with_margin():
    """With --cavity-law s2s (the default law may become s2s) the default patch size on the default mesh is
    far inside the limits: under a tenth of the patch limit, of an hour of CPU and of 1 GiB."""
    from imutherm.budget import MAX_PATCHES, MAX_S2S_S, s2s_cost
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.layout import load_layout
    from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS
    from imutherm.unit.model import ModelOptions, s2s_patches

    opts = ModelOptions(cavity_law="s2s")
    for scheme in ("air", "grease", "potted"):
        n = s2s_patches(build_geometry(load_layout(None), scheme), opts, DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS)
        mem, sec = s2s_cost(n, opts.cavity_rays)
        assert n < MAX_PATCHES / 5 and sec < MAX_S2S_S / 10 and mem < 2**30, (scheme, n, mem, sec)
    assert s2s_patches(build_geometry(load_layout(None), "grease"), ModelOptions(cavity_law="effective"), 6, 1) == 0


def test_s2s_library_refuses_before_the_dense_arrays(monkeypatch):
    """The library itself (sweep cases, correlate builds, scripts) counts the patches before view factors."""
    import imutherm.thermal.cavity_radiation as cr
    from imutherm import InputError
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.layout import load_layout
    from imutherm.geometry.mesh import build_mesh

    monkeypatch.setattr(cr, "view_factors", _fail)
    grid = build_mesh(build_geometry(load_layout(None), "air"), 6, 1)
    air = grid.cell_part == grid.part_names.index("fill")
    with pytest.raises(InputError, match="cavity patches.*limit of 10,000 patches"):
        cr.cavity_exchange(grid, air, [0.9] * len(grid.part_names), patch_mm=0.001)


SWEEP_ARGV = ["sweep", "--scheme", "grease", "--set", "environment.ambient_C=20,30,40", *COARSE]


def _damaged_sweep(folder: Path, damage) -> None:
    """A sweep record of SWEEP_ARGV's design in ``folder`` (no case run) with ``damage`` applied to its rows."""
    import json

    from imutherm.studies.sweep import plan_sweep
    from imutherm.thermal.cavity_radiation import AUTO_MAX_PATCHES
    from imutherm.unit.model import ModelOptions

    # the command line's model options: its s2s patch edge follows the patch-count rule (cli/_options.py)
    plan = plan_sweep(None, "grease", ["environment.ambient_C=20,30,40"], mesh_size_mm=6, min_cells=1,
                      options=ModelOptions(cavity_max_patches=AUTO_MAX_PATCHES))
    folder.mkdir()
    (folder / "sweep.json").write_text(json.dumps({"design": plan.design, "status": "running"}, default=str))
    good = [f"{i},{v:.1f}," + ",".join(["1.0"] * (len(plan.columns) - 5)) + ",ok,,1.0" for i, v in
            enumerate((20.0, 30.0, 40.0))]
    (folder / "results.csv").write_bytes(damage(",".join(plan.columns).encode() + b"\n",
                                                [g.encode() for g in good[:2]]))


DAMAGE = {  # name -> (bytes from header and two good rows, expected tokens)
    "random_bytes": (lambda h, r: h + r[0] + b"\n" + bytes(range(128, 256)) + b"\n", ["results.csv:3", "not UTF-8"]),
    "nul": (lambda h, r: h + r[0] + b"\n" + r[1].replace(b",ok", b",o\0k") + b"\n", ["results.csv:3", "NUL"]),
    "case_id_text": (lambda h, r: h + r[0] + b"\n" + b"x" + r[1][1:] + b"\n", ["results.csv:3", "'case'", "integer"]),
    "value_text": (lambda h, r: h + r[0].replace(b",1.0,", b",hot,", 1) + b"\n", ["results.csv:2", "'hot'"]),
    "case_id_out_of_design": (lambda h, r: h + b"7" + r[0][1:] + b"\n", ["results.csv:2", "case id 7"]),
    "input_not_the_design": (lambda h, r: h + r[1].replace(b",30.0,", b",31.0,") + b"\n",
                             ["results.csv:2", "31.0", "30.0"]),
    "status": (lambda h, r: h + r[0].replace(b",ok,", b",maybe,") + b"\n", ["results.csv:2", "'maybe'"]),
    "header": (lambda h, r: b"case,what\n" + r[0] + b"\n", ["results.csv:1", "columns"]),
}


@pytest.mark.parametrize("case", list(DAMAGE))
def test_damaged_sweep_resume_is_refused_naming_the_row(case, tmp_path, capsys, no_expensive):
    folder = tmp_path / "sw"
    _damaged_sweep(folder, DAMAGE[case][0])
    before = _snapshot(folder)
    code, err = _run(SWEEP_ARGV + ["--resume", "--out", str(folder)], capsys)
    _assert_refused(code, err, DAMAGE[case][1])
    assert _snapshot(folder) == before


@pytest.mark.parametrize("text", [bytes(range(256)), b"[1, 2]", b'{"design": 3}', b"{"])
def test_damaged_sweep_json_is_refused(text, tmp_path, capsys, no_expensive):
    folder = tmp_path / "sw"
    _damaged_sweep(folder, lambda h, r: h + r[0] + b"\n")
    (folder / "sweep.json").write_bytes(text)
    code, err = _run(SWEEP_ARGV + ["--resume", "--out", str(folder)], capsys)
    _assert_refused(code, err, ["--resume", "sweep.json"])


def test_a_cut_last_row_is_the_one_repair(tmp_path):
    """A kill mid-write leaves a last line without its newline: dropped (its case runs again), the rest kept."""
    from imutherm.studies.sweep import plan_sweep, read_results

    plan = plan_sweep(None, "grease", ["environment.ambient_C=20,30,40"], mesh_size_mm=6, min_cells=1)
    _damaged_sweep(tmp_path / "sw", lambda h, r: h + r[0] + b"\n" + r[1][:12])
    rows = read_results(tmp_path / "sw" / "results.csv", plan.columns, plan.cases, plan.keys)
    assert [r["case"] for r in rows] == [0]
    assert (tmp_path / "sw" / "results.csv").read_bytes().endswith(b",ok,,1.0\n")


def test_an_inherited_sigint_ignore_is_honoured(out):
    """Started with SIGINT ignored (as a background job of a non-interactive shell), the command keeps it,
    as programs conventionally do: Ctrl-C does not stop it (SIGKILL then does, leaving ``out`` untouched)."""
    before = _snapshot(out)
    proc = _spawn(out, pause="solving", sigint=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    _wait_for_pause(proc, "solving")
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=3)
    except subprocess.TimeoutExpired:
        pass
    alive = proc.poll() is None
    proc.kill()
    proc.communicate(timeout=60)
    assert alive, "the run stopped at SIGINT although it was started with SIGINT ignored"
    assert _snapshot(out) == before


# --------------------------------------------------------------------------- board files and import options
def _kicad(parts=None, **kw) -> str:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from kicad_writer import kicad_board, part

    parts = parts if parts is not None else [part("U1", "Package_SO:SOIC-8_3.9x4.9mm", (110, 110, 0),
                                                  fields={"Power_W": "0.1"})]
    return kicad_board(parts, **kw)


def _idf(outline_lines=None, ref="U1") -> tuple:
    """(.emn text, .emp text) of a 40 x 30 mm IDF board with one 0.1 W SOIC."""
    outline = outline_lines or ["0 0 0 0", "0 40 0 0", "0 40 30 0", "0 0 30 0", "0 0 0 0"]
    emn = "\n".join([".HEADER", 'BOARD_FILE 3.0 "t" 2026/01/01.00:00:00 1', '"b" MM', ".END_HEADER",
                     ".BOARD_OUTLINE ECAD", "1.6", *outline, ".END_BOARD_OUTLINE", ".PLACEMENT",
                     f'"SOIC8" "P1" "{ref}"', "20 15 0 0 TOP PLACED", ".END_PLACEMENT"]) + "\n"
    emp = "\n".join([".HEADER", 'LIBRARY_FILE 3.0 "t" 2026/01/01.00:00:00 1', ".END_HEADER", ".ELECTRICAL",
                     '"SOIC8" "P1" MM 1.75', "PROP POWER_OPR 0.1", "0 -2 -2.5 0", "0 2 -2.5 0", "0 2 2.5 0",
                     "0 -2 2.5 0", "0 -2 -2.5 0", ".END_ELECTRICAL"]) + "\n"
    return emn, emp


@functools.lru_cache(maxsize=1)
def _import_board_cases() -> dict:
    """name -> (file name, text or (emn, emp), extra options, words of the refusal)."""
    angles = [k * 2 * math.pi / 1_000_000 for k in range(1_000_000)]
    circle = [f"0 {20 + 15 * math.cos(a):.6f} {15 + 15 * math.sin(a):.6f} 0" for a in angles]
    arc = "  (gr_arc (start 120 115) (end 125 115) (angle 1e12) (layer Edge.Cuts) (width 0.05))"
    twin = ('(footprint "X:Y" (layer "F.Cu") (at 125 110 0) (property "Reference" "U1") '
            '(pad "1" smd rect (at 0 0) (size 1 1) (layers "F.Cu")))\n  (footprint')
    nan_poly = '  (gr_poly (pts (xy 100 100) (xy nan 100) (xy 140 130)) (layer "Edge.Cuts") (width 0.05))'
    return {
        "nan_in_outline": ("b.kicad_pcb", _kicad(extra=nan_poly), [],
                           "Edge.Cuts): poly point: expected a number, got 'nan'"),
        "inf_in_outline": ("b.kicad_pcb", _kicad().replace("(start 140.0 100.0)", "(start 1e999 100.0)", 1), [],
                           "expected a number, got inf"),
        "arc_of_1e12_degrees": ("b.kicad_pcb", _kicad(dialect="kicad5", extra=arc), [],
                                "an arc of 1e+12 degrees; an arc turns at most 360 degrees"),
        "at_with_one_number": ("b.kicad_pcb", _kicad().replace("(at 110 110 0)", "(at 88.9)", 1), [],
                               "(at 88.9) needs x and y"),
        "version_1e999": ("b.kicad_pcb", _kicad().replace("(version 20221018)", "(version 1e999)"), [],
                          "(version inf): not a KiCad file version"),
        "del_in_reference": ("b.kicad_pcb", _kicad().replace('"U1"', '"U\x7f1"', 1), [],
                             "holds the control character U+007F"),
        "coordinate_beyond_kicad": ("b.kicad_pcb", _kicad().replace("(at 110 110 0)", "(at 110 9e9 0)", 1), [],
                                    "outside KiCad's coordinate range"),
        "idf_arc_of_1e12_degrees": ("b.emn", _idf(["0 0 0 0", "0 40 0 1e12", "0 40 30 0", "0 0 30 0", "0 0 0 0"]), [],
                                    "line 8: an arc of 1e+12 degrees"),
        "idf_million_point_outline": ("b.emn", _idf(circle + [circle[0]]), [],
                                      "the board outline has 1,000,001 points; at most 200,000"),
        "idf_del_in_reference": ("b.emn", _idf(ref="U\x7f1"), [], "holds the control character U+007F"),
        "duplicate_reference_named": ("b.kicad_pcb", _kicad().replace("(footprint", twin, 1), ["--site", "U1=imu"],
                                      "U1 is a duplicate reference: 2 footprints carry it"),
    }


IMPORT_OPTION_CASES = {
    "ambient_nan": (["--ambient", "nan"], "--ambient nan: valid: a number in -60..150 degC"),
    "ambient_inf": (["--ambient", "inf"], "--ambient inf"),
    "ambient_past_the_layout": (["--ambient", "400"], "--ambient 400.0"),
    "mount_conductance_nan": (["--mount-conductance", "nan"], "--mount-conductance nan"),
    "clearance_inf": (["--clearance", "inf"], "--clearance inf"),
    "wall_nan": (["--wall", "nan"], "--wall nan"),
    "merge_area_nan": (["--merge-area", "nan"], "--merge-area nan"),
    "board_name_climbing_out": (["--board", "../../x"], "--board '../../x': valid: a name of letters"),
    "layout_name_with_a_slash": (["--name", "a/../b"], "--name 'a/../b'"),
}


def _write_board(folder: Path, name: str, content) -> Path:
    path = folder / name
    if isinstance(content, tuple):
        path.write_text(content[0])
        path.with_suffix(".emp").write_text(content[1])
    else:
        path.write_text(content)
    return path


@pytest.mark.parametrize("case", list(_import_board_cases()) + list(IMPORT_OPTION_CASES))
def test_bad_board_file_or_import_option(case, tmp_path, capsys):
    """Refused in one line, exit status 2, no traceback, nothing written beside the inputs (no layout, no
    temporary); an earlier layout at --out with --force stays byte-identical."""
    cases = _import_board_cases()
    name, content, extra, words = (cases[case] if case in cases else
                                   ("b.kicad_pcb", _kicad(), *IMPORT_OPTION_CASES[case]))
    board = _write_board(tmp_path, name, content)
    site = [] if "--site" in extra else ["--site", "U1=probe"]
    before = sorted(os.listdir(tmp_path))
    code, err = _run(["import", str(board), "--height", "U1=1.75", *site, *extra, "--out", str(tmp_path / "unit.toml")],
                     capsys)
    _assert_refused(code, err, words)
    assert sorted(os.listdir(tmp_path)) == before
    (tmp_path / "unit.toml").write_text("the user's earlier layout\n")
    code, err = _run(["import", str(board), "--height", "U1=1.75", *site, *extra, "--force", "--out",
                      str(tmp_path / "unit.toml")], capsys)
    _assert_refused(code, err, words)
    assert (tmp_path / "unit.toml").read_text() == "the user's earlier layout\n"
    assert sorted(os.listdir(tmp_path)) == sorted(before + ["unit.toml"])


def _spawn_import(board: Path, out: Path, pause: str | None = None):
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    if pause:
        env.update(IMUTHERM_TEST_PAUSE=pause, IMUTHERM_TEST_PAUSE_S="60")
    code = "import sys; from imutherm.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.Popen([sys.executable, "-c", code, "import", str(board), "--height", "U1=1.75", "--site",
                             "U1=probe", "--force", "--out", str(out)], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=_default_sigint)


def test_a_killed_import_leaves_its_temporary_and_the_next_import_removes_it(tmp_path):
    """SIGKILL with the layout written to its temporary, not yet renamed (the test pause there): the earlier
    layout is untouched and `.unit.XXXXXXXX.toml` is left; meanwhile a second import into the same file is
    refused (the file is locked); the next import removes the temporary, says so, and writes the layout."""
    board = _write_board(tmp_path, "b.kicad_pcb", _kicad())
    out = tmp_path / "unit.toml"
    out.write_text("the user's earlier layout\n")
    proc = _spawn_import(board, out, "import-written")
    _wait_for_pause(proc, "import-written")
    second = _spawn_import(board, out)
    _, err = second.communicate(timeout=120)
    assert second.returncode == 2 and "another imutherm run" in err and "Traceback" not in err, err
    proc.kill()
    proc.communicate(timeout=60)
    left = sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".unit."))
    assert len(left) == 1 and left[0].endswith(".toml") and out.read_text() == "the user's earlier layout\n"
    again = _spawn_import(board, out)
    text, err = again.communicate(timeout=120)
    assert again.returncode == 0, err
    assert f"removed {left[0]}, the temporary of an earlier import into {out} that was killed" in text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.kicad_pcb", "unit.toml"]
    assert "imported by imutherm import" in out.read_text()


def test_force_keeps_the_replaced_layouts_permissions(tmp_path, capsys):
    board = _write_board(tmp_path, "b.kicad_pcb", _kicad())
    args = ["import", str(board), "--height", "U1=1.75", "--site", "U1=probe"]
    old_umask = os.umask(0o022)
    try:
        assert _run(args + ["--out", str(tmp_path / "new.toml")], capsys)[0] == 0
        assert oct((tmp_path / "new.toml").stat().st_mode & 0o777) == "0o644"   # a new file: 0666 less the umask
        out = tmp_path / "unit.toml"
        out.write_text("old\n")
        os.chmod(out, 0o640)
        assert _run(args + ["--force", "--out", str(out)], capsys)[0] == 0
        assert oct(out.stat().st_mode & 0o777) == "0o640" and "imported by imutherm import" in out.read_text()
    finally:
        os.umask(old_umask)
