"""``imutherm sweep``: design checks, sampling, failing cases, kill + resume, --jobs, Dask, the PDF (coarse mesh)."""

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from imutherm.cli import main
from imutherm.studies import sweep as sweep_mod
from imutherm.studies.sweep import run as sweep_run
from imutherm.studies.sweep import plan_sweep, sensitivity

COARSE = ["--mesh-size", "6", "--min-cells", "1", "--no-progress"]
POWER = "components.reg_5v.power_W"
DESIGN = ["--scheme", "grease", "--surrogate", "none", "--set", f"{POWER}=0.4,0.8,1.2"]
ROOT = Path(__file__).resolve().parents[1]


def _rows(out: Path) -> list:
    with open(out / "results.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _same_rows(a: list, b: list) -> None:
    """Same case ids, inputs and status; outputs equal to floating-point reduction order."""
    assert [r["case"] for r in a] == [r["case"] for r in b]
    for ra, rb in zip(a, b):
        assert set(ra) == set(rb)
        for col in ra:
            if col == "seconds":
                continue
            if col.endswith("_K") or col.endswith("_s"):
                assert float(ra[col]) == pytest.approx(float(rb[col]), rel=1e-9, abs=1e-12), (ra["case"], col)
            else:
                assert ra[col] == rb[col], (ra["case"], col)


def _no_run(*args, **kwargs):
    raise AssertionError("no case may run")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted three-case sweep, one process."""
    out = tmp_path_factory.mktemp("sweep") / "ref"
    assert main(["sweep", *DESIGN, "--out", str(out), *COARSE]) == 0
    return out


# ---------------------------------------------------------------- checked before any case runs
@pytest.mark.parametrize("item, expect", [
    ("components.reg5v.power_W=1", "nearest valid: components.reg_5v.power_W"),
    ("materials.silicone_greas.k=1", "materials.silicone_grease.k"),
    ("options.emisivity=0.5", "options.emissivity"),
    ("mounting.contact_conductance=100", "mounting.contact_conductance_W_m2K"),
    (f"{POWER}=abc", "'abc' is not a number"),
    (f"{POWER}=0.4,x", "'x' is not a number"),
    (f"{POWER}=1:0:3", "lo < hi"),
    (f"{POWER}=0:1:1", "n must be an integer >= 2"),
    (f"{POWER}=0:1:2.5", "n must be an integer >= 2"),
    (f"{POWER}=0:1", "a grid range needs a count"),
    (f"{POWER}=0.4,0.4", "repeated value"),
    (f"{POWER}=nan", "finite"),
    (f"{POWER}", "expected KEY=VALUES"),
    (f"{POWER}=0.4,-1", "case 1 (components.reg_5v.power_W=-1) is refused"),   # the layout's own check
    ("housing.wall_mm=30", "walls, base and lid leave no cavity"),
    ("boards.main.min_mm.2=0", "bond bridges"),                                 # the geometry's check
    ("materials.silicone_grease.k=0,1", "must be a finite number > 0"),         # the material library's check
    ("options.emissivity=0.5,1.5", "emissivity must be in [0, 1]"),             # the model options' check
])
def test_bad_set_refused_before_any_case(tmp_path, monkeypatch, capsys, item, expect):
    monkeypatch.setattr(sweep_run, "run_case", _no_run)
    out = tmp_path / "s"
    assert main(["sweep", "--scheme", "grease", "--set", item, "--out", str(out), *COARSE]) == 2
    err = capsys.readouterr().err
    assert expect in err and err.count("\n") == 1
    assert not out.exists()


def test_bad_design_options_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(sweep_run, "run_case", _no_run)
    out = str(tmp_path / "s")
    cases = [
        (["--set", f"{POWER}=0.4,0.8", "--set", f"{POWER}=1"], "given twice"),
        (["--method", "lhs", "--set", f"{POWER}=0.4,0.8", "--samples", "4", "--seed", "1"], "give lo:hi, not a list"),
        (["--method", "lhs", "--set", f"{POWER}=0.4:0.8:3", "--samples", "4", "--seed", "1"], "give the range as lo:hi"),
        (["--method", "lhs", "--set", f"{POWER}=0.4:0.8", "--seed", "1"], "needs --samples"),
        (["--method", "morris", "--set", f"{POWER}=0.4:0.8", "--samples", "4"], "needs --seed"),
        (["--set", f"{POWER}=0.4,0.8", "--seed", "3"], "belong to --method lhs or morris"),
        ([], "at least one --set"),
    ]
    for args, expect in cases:
        assert main(["sweep", "--scheme", "grease", *args, "--out", out, *COARSE]) == 2
        assert expect in capsys.readouterr().err
    assert not Path(out).exists()


def test_valid_keys_cover_layout_materials_and_options():
    from imutherm.geometry.layout import load_layout, default_layout_path
    import tomllib

    raw = tomllib.loads(default_layout_path().read_text())
    keys = sweep_mod.valid_keys(raw, load_layout(), "grease")
    for k in (POWER, "environment.ambient_C", "mounting.contact_conductance_W_m2K", "housing.outer_mm.0",
              "components.accel_x.die_base_mm", "schemes.grease.max_bond_gap_mm", "materials.silicone_grease.k",
              "materials.pcb_fr4_4layer.k_through", "materials.pcb_via_field.k_through", "options.emissivity",
              "options.cavity_emissivity"):
        assert k in keys, k
    assert "schemes.air.max_bond_gap_mm" not in keys            # another scheme's field has no effect
    assert "materials.potting_compound.k" not in keys            # not used by the grease scheme
    assert keys["mounting.contact_conductance_W_m2K"] == "W/m^2 K" and keys[POWER] == "W"


def test_material_override_reaches_the_model_not_the_library():
    from imutherm.geometry.materials import get_material

    plan = plan_sweep(None, "grease", ["materials.silicone_grease.k=0.3,3"], mesh_size_mm=6, min_cells=1)
    assert [c.options.material("silicone_grease").k_through for c in plan.cases] == [0.3, 3.0]
    assert get_material("silicone_grease").k_in_plane == 0.6                     # library untouched
    assert plan.cases[0].options.material("air") is get_material("air")


# ---------------------------------------------------------------- designs from SALib
def test_lhs_and_morris_designs_size_and_seed():
    sets = [f"{POWER}=0.4:1.2", "materials.silicone_grease.k=0.3:1.2"]
    kw = dict(mesh_size_mm=6, min_cells=1)
    a = plan_sweep(None, "grease", sets, method="lhs", samples=7, seed=3, **kw)
    b = plan_sweep(None, "grease", sets, method="lhs", samples=7, seed=3, **kw)
    c = plan_sweep(None, "grease", sets, method="lhs", samples=7, seed=4, **kw)
    assert a.X.shape == (7, 2) and np.array_equal(a.X, b.X) and not np.array_equal(a.X, c.X)
    # Latin hypercube: one sample in each of the 7 strata of every input
    for j, (lo, hi) in enumerate([(0.4, 1.2), (0.3, 1.2)]):
        strata = np.floor((a.X[:, j] - lo) / (hi - lo) * 7).astype(int)
        assert sorted(strata) == list(range(7))
    m = plan_sweep(None, "grease", sets, method="morris", samples=4, seed=3, **kw)
    m2 = plan_sweep(None, "grease", sets, method="morris", samples=4, seed=3, **kw)
    assert m.X.shape == (4 * 3, 2) and np.array_equal(m.X, m2.X)   # 4 trajectories of (2 inputs + 1) points
    assert len(m.cases) == 12 and m.design["seed"] == 3


def _synthetic_rows(plan, f):
    rows = []
    for c in plan.cases:
        y = f(*c.values)
        row = {"case": c.case_id, **dict(zip(plan.keys, c.values)), "status": "ok", "message": "", "seconds": 0.0}
        row.update({o: y for o in plan.outputs})
        rows.append(row)
    return rows


def test_sensitivity_measures_on_a_known_function():
    # y = 10 P + 1 k: the power range 0.8 W moves y by 8, the grease range 0.9 W/m K by 0.9
    f = lambda p, k: 10 * p + 1 * k  # noqa: E731
    sets = [f"{POWER}=0.4:1.2", "materials.silicone_grease.k=0.3:1.2"]
    m = plan_sweep(None, "grease", sets, method="morris", samples=6, seed=1, mesh_size_mm=6, min_cells=1)
    s = sensitivity(m, _synthetic_rows(m, f))
    assert s["measure"] == "morris_mu_star" and s["ranking"] == [POWER, "materials.silicone_grease.k"]
    by = s["outputs"]["max_rise_K"]["by_key"]
    assert by[POWER]["sigma"] == pytest.approx(0, abs=1e-9)                 # linear: no interaction
    # SALib's elementary effects are per unit of the normalised range: mu* = |a| (hi - lo)
    assert by[POWER]["mu_star"] == pytest.approx(10 * 0.8, rel=1e-9)
    assert by["materials.silicone_grease.k"]["mu_star"] == pytest.approx(1 * 0.9, rel=1e-9)
    # a failed case: Morris needs the whole design, SRC is given and said so
    rows = _synthetic_rows(m, f)
    rows[0].update(status="failed", message="x")
    s2 = sensitivity(m, rows)
    assert s2["measure"] == "src" and "Morris measures need every case" in s2["note"]
    # grid: exact linear response -> R^2 = 1 and SRC_i = a_i std(x_i) / std(y)
    g = plan_sweep(None, "grease", [f"{POWER}=0.4,0.8,1.2", "materials.silicone_grease.k=0.3,1.2"],
                   mesh_size_mm=6, min_cells=1)
    s3 = sensitivity(g, _synthetic_rows(g, f))
    X = g.X
    y = 10 * X[:, 0] + X[:, 1]
    assert s3["outputs"]["max_rise_K"]["r2"] == pytest.approx(1.0, abs=1e-12)
    assert s3["outputs"]["max_rise_K"]["by_key"][POWER]["src"] == pytest.approx(10 * X[:, 0].std() / y.std(), rel=1e-9)


# ---------------------------------------------------------------- running
@pytest.mark.slow
def test_reference_sweep_rows_and_record(reference):
    rows = _rows(reference)
    assert [r["case"] for r in rows] == ["0", "1", "2"]
    assert [float(r[POWER]) for r in rows] == [0.4, 0.8, 1.2]
    assert all(r["status"] == "ok" and r["message"] == "" and float(r["seconds"]) > 0 for r in rows)
    rise = [float(r["max_rise_K"]) for r in rows]
    assert rise[0] < rise[1] < rise[2]                        # more regulator power, hotter
    for r in rows:
        assert float(r["max_rise_K"]) >= max(float(r[c]) for c in r if c.startswith("rise_"))
    rec = json.loads((reference / "sweep.json").read_text())
    assert rec["status"] == "complete" and rec["counts"]["ok"] == 3
    assert rec["design"]["factors"][0]["key"] == POWER and rec["sensitivity"]["ranking"] == [POWER]
    assert rec["timing"]["case_s_mean"] > 0


@pytest.mark.slow
def test_failing_case_recorded_and_sweep_goes_on(tmp_path, capsys):
    # without exterior convection and radiation, a zero mounting conductance leaves no path for the heat:
    # the solver refuses that case when it runs; the other case is fine
    out = tmp_path / "f"
    assert main(["sweep", "--scheme", "grease", "--surrogate", "none", "--exterior", "none", "--no-radiation",
                 "--set", "options.mounting_conductance_W_m2K=0,500", "--out", str(out), *COARSE]) == 0
    rows = _rows(out)
    assert [r["status"] for r in rows] == ["failed", "ok"]
    assert "no boundary law removes heat" in rows[0]["message"] and rows[0]["max_rise_K"] == ""
    assert float(rows[1]["max_rise_K"]) > 0
    assert "case 0 failed" in capsys.readouterr().out
    # the PDF names the inputs and outputs
    from pypdf import PdfReader

    text = "".join(p.extract_text() for p in PdfReader(out / "sweep.pdf").pages)
    assert "options.mounting_conductance_W_m2K" in text and "max_rise_K" in text


@pytest.mark.slow
def test_pdf_names_the_inputs(reference):
    from pypdf import PdfReader

    reader = PdfReader(reference / "sweep.pdf")
    text = "".join(p.extract_text() for p in reader.pages)
    assert POWER in text and "standardised regression coefficient" in text and "[W]" in text
    assert len(reader.pages) == 3  # ranking, table, one scatter page per input


@pytest.mark.slow
def test_existing_sweep_needs_resume_and_same_design(reference, tmp_path, monkeypatch, capsys):
    import shutil

    out = tmp_path / "copy"
    shutil.copytree(reference, out)
    monkeypatch.setattr(sweep_run, "run_case", _no_run)
    assert main(["sweep", *DESIGN, "--out", str(out), *COARSE]) == 2
    assert "add --resume" in capsys.readouterr().err
    assert main(["sweep", "--scheme", "grease", "--surrogate", "none", "--set", f"{POWER}=0.4,0.8,1.3", "--resume",
                 "--out", str(out), *COARSE]) == 2
    assert "differs from the one recorded" in capsys.readouterr().err
    assert main(["sweep", "--scheme", "air", "--surrogate", "none", "--set", f"{POWER}=0.4,0.8,1.2", "--resume",
                 "--out", str(out), *COARSE]) == 2
    assert "scheme" in capsys.readouterr().err
    # complete: a resume runs nothing and leaves the rows as they were
    assert main(["sweep", *DESIGN, "--resume", "--out", str(out), *COARSE]) == 0
    _same_rows(_rows(out), _rows(reference))


@pytest.mark.slow
def test_killed_sweep_resumes_to_the_same_rows(reference, tmp_path):
    out = tmp_path / "k"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-c", "import sys; from imutherm.cli import main; sys.exit(main())",
           "sweep", *DESIGN, "--out", str(out), *COARSE]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 600
        while time.monotonic() < deadline and proc.poll() is None:
            if (out / "results.csv").exists() and len(_rows(out)) >= 1:
                break
            time.sleep(0.2)
        assert proc.poll() is None, "the sweep ended before it could be killed"
        os.killpg(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    before = _rows(out)
    assert 1 <= len(before) < 3
    assert json.loads((out / "sweep.json").read_text())["status"] == "running"
    assert main(["sweep", *DESIGN, "--resume", "--out", str(out), *COARSE]) == 0
    after = _rows(out)
    assert len({r["case"] for r in after}) == len(after) == 3
    _same_rows(after, _rows(reference))
    rec = json.loads((out / "sweep.json").read_text())
    assert rec["counts"]["ran_this_call"] == 3 - len(before)


@pytest.mark.slow
def test_two_jobs_give_the_rows_of_one(reference, tmp_path):
    out = tmp_path / "j2"
    assert main(["sweep", *DESIGN, "--jobs", "2", "--out", str(out), *COARSE]) == 0
    _same_rows(_rows(out), _rows(reference))


@pytest.mark.slow
def test_dask_local_cluster_gives_the_rows_of_the_local_run(reference, tmp_path):
    from distributed import LocalCluster

    out = tmp_path / "dask"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        assert main(["sweep", *DESIGN, "--dask", cluster.scheduler_address, "--out", str(out), *COARSE]) == 0
    _same_rows(_rows(out), _rows(reference))


def test_dask_unreachable_scheduler_is_one_line(tmp_path, capsys):
    out = tmp_path / "d"
    assert main(["sweep", *DESIGN, "--dask", "tcp://127.0.0.1:9", "--out", str(out), *COARSE]) == 2
    assert "cannot connect to a Dask scheduler" in capsys.readouterr().err


@pytest.mark.slow
def test_transient_sweep_adds_t95_of_the_hottest_site(tmp_path):
    out = tmp_path / "t"
    assert main(["sweep", "--scheme", "grease", "--surrogate", "none", "--set", f"{POWER}=0.8", "--transient", "--t-end", "400",
                 "--out", str(out), *COARSE]) == 0
    (row,) = _rows(out)
    assert row["status"] == "ok"
    # the hottest site is tp1 (beside the regulators); it settles within the run, not at its first step
    assert 20.0 < float(row["t95_s"]) < 400.0
    assert float(row["rise_tp1_K"]) == max(float(row[c]) for c in row if c.startswith("rise_"))
    assert json.loads((out / "sweep.json").read_text())["design"]["t_end_s"] == 400.0


@pytest.mark.slow
def test_attitude_columns_are_the_end_to_end_metrics_of_the_case(tmp_path):
    from imutherm.studies.end_to_end import scheme_attitude_metrics
    from imutherm.studies.thermal.thermal_study import run_scheme
    from imutherm.unit.model import ModelOptions

    out = tmp_path / "a"
    assert main(["sweep", "--scheme", "grease", "--set", "options.emissivity=0.5", "--attitude",
                 "--out", str(out), *COARSE]) == 0
    (row,) = _rows(out)
    assert row["status"] == "ok", row["message"]
    cols = sweep_mod.attitude_columns(False)
    assert "steady_improved_gated_flight_roll_rms_deg" in cols and all(c in row for c in cols)
    # one call per case, seeds 0.. (the same in every case): equal to the study's own function on that case
    res = run_scheme(None, "grease", mesh_size_mm=6, min_cells=1, options=ModelOptions(emissivity=0.5))
    direct = scheme_attitude_metrics(res, seeds=1, seed0=0)
    for c in cols:
        assert float(row[c]) == pytest.approx(direct[c], rel=1e-9)
    assert 0 < float(row["steady_improved_gated_flight_roll_rms_deg"]) < 5.0
    from pypdf import PdfReader

    text = "".join(p.extract_text() for p in PdfReader(out / "sweep.pdf").pages)
    assert "roll RMS error" in text


def test_jobs_beyond_the_cases_run_on_as_many_workers_as_cases(tmp_path, capsys, monkeypatch):
    """``--jobs 10000`` on a 2-case sweep is estimated and run on 2 workers, not refused for 10,000 workers'
    memory (the run itself is replaced: what is checked is what the cost model counts and what it starts)."""
    import imutherm.cli.sweep as sweep_cli

    seen = {}

    def fake_run_sweep(plan, out, *, jobs, **kw):
        seen["jobs"] = jobs
        raise KeyboardInterrupt   # stop here: the sweep's checks and estimate are done

    monkeypatch.setattr(sweep_cli, "run_sweep", fake_run_sweep)
    rc = main(["sweep", "--scheme", "grease", "--surrogate", "none", "--set", f"{POWER}=0.4,0.8", "--jobs", "10000",
               "--out", str(tmp_path / "s"), *COARSE])
    out = capsys.readouterr().out
    assert seen["jobs"] == 2 and rc != 0
    assert "2 local processes (--jobs 10000: 2 cases)" in out


def test_usable_workers_and_the_study_cost_count_the_tasks():
    from imutherm.studies.cost import check_study_cost
    from imutherm.workers import usable_workers
    from imutherm.studies.end_to_end import StudyConfig

    assert usable_workers(10000, 2) == 2 and usable_workers(1, 9) == 1 and usable_workers(3, 0) == 1
    work = check_study_cost(StudyConfig(), 3, 1000, None)     # 9 cases: 8 IMU workers beside the thermal one
    assert work["memory_bytes"] < 4 * 2**30


def test_the_schemes_side_by_side_count_one_refined_solve_beside_the_other_workers():
    """``compare``'s thermal workers at once: the largest refined solve beside the largest other solves (one refined
    solve at a time), plus the command; one worker is the schemes' own checks; beyond the limit a one-line refusal
    naming --jobs 1 and --no-mesh-error."""
    from imutherm import InputError
    from imutherm.budget import BASE_BYTES
    from imutherm.studies.cost import check_schemes_side_by_side

    MB = 2**20
    solves, refined = [700 * MB, 600 * MB, 500 * MB], [1750 * MB, 1500 * MB, 1200 * MB]
    assert check_schemes_side_by_side(solves, refined, 2, None) == BASE_BYTES + 1750 * MB + 700 * MB
    assert check_schemes_side_by_side(solves, refined, 1000, None) == BASE_BYTES + 1750 * MB + 1300 * MB
    assert check_schemes_side_by_side(solves, [], 2, None) == BASE_BYTES + 1300 * MB
    assert check_schemes_side_by_side(solves, refined, 1, 1800 * MB) == 1750 * MB   # one worker: its own checks
    assert check_schemes_side_by_side(solves[:1], refined[:1], 8, 1800 * MB) == 1750 * MB   # one scheme: one worker
    with pytest.raises(InputError, match=r"2 schemes solved side by side \(--jobs 2\).*use --jobs 1 .* or "
                                         r"--no-mesh-error"):
        check_schemes_side_by_side(solves, refined, 2, 2 * 2**30)
    with pytest.raises(InputError, match="--jobs: 0 is invalid"):
        check_schemes_side_by_side(solves, refined, 0, None)
