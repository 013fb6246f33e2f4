"""Each measured figure has one source, a table file under ``docs/benchmarks/tables/`` that its benchmark writes.

The answer of ``imutherm compare``: ``compare_answer.txt``, and the run's timing: ``study.txt``, both written by
``python benchmarks/bench_study.py --write``. The docs pages include them (so they cannot show another table),
the README's copies (a GitHub page cannot include a file) must be the same, and the figures the getting-started
page reads out of the answer must be in it.

(The gallery's stated figures are held to what the examples print in tests/test_gallery.py.)"""

import importlib.util
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TABLES = ROOT / "docs" / "benchmarks" / "tables"
ANSWER = TABLES / "compare_answer.txt"
TIMING = TABLES / "study.txt"
OVEN = TABLES / "oven_self_heating.txt"
TABLE_HEAD = "scheme   max rise [K]"
DECIMAL = re.compile(r"(?<![\w.])\d+\.\d+(?![\w.])")


def answer() -> list:
    return [line for line in ANSWER.read_text(encoding="utf-8").splitlines() if not line.startswith("#")]


def test_the_answer_file_says_where_it_comes_from():
    header = [line for line in ANSWER.read_text(encoding="utf-8").splitlines() if line.startswith("#")]
    assert any("python benchmarks/bench_study.py --write" in line and re.search(r"commit [0-9a-f]{7}", line)
               for line in header), header
    lines = answer()
    assert lines[0].startswith(TABLE_HEAD)
    schemes = [line.split()[0] for line in lines if re.match(r"^(air|grease|potted) +\d", line)]
    assert schemes == ["air", "grease", "potted"]
    table = lines[:next(i for i, line in enumerate(lines) if line.startswith("filters at their"))]
    for filt in ("gated", "kf", "ungated", "fusion", "aekf", "vqf"):   # all six filters of the answer, per scheme
        assert sum(f" {filt} " in f" {line}" for line in table) == 3, filt


def test_the_readme_shows_the_recorded_answer():
    """The README's printout: its table and notes line for line, its first sentence word for word (the README
    wraps the sentences)."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(readme) if line.startswith(TABLE_HEAD))
    first_sentence = next(i for i in range(start, len(readme)) if readme[i].startswith("air: "))
    lines = answer()
    n = next(i for i, line in enumerate(lines) if line.startswith("air: "))
    assert readme[start:first_sentence] == lines[:n]
    end = next(i for i in range(first_sentence, len(readme)) if readme[i].startswith("..."))
    assert " ".join(" ".join(readme[first_sentence:end]).split()) in " ".join(" ".join(lines[n:]).split())
    # after the '...', the numerical-error lines, as recorded
    wrote = next(i for i in range(end, len(readme)) if readme[i].startswith("wrote "))
    assert readme[end + 1:wrote] == [line for line in lines if line.startswith("numerical error")]


def test_the_docs_include_the_answer_and_hold_no_copy():
    text = ANSWER.read_text(encoding="utf-8")
    row = next(line for line in answer() if line.startswith("air "))
    for page in ("getting-started.md", "reference/study.md"):
        doc = (ROOT / "docs" / page).read_text(encoding="utf-8")
        assert "tables/compare_answer.txt" in doc and "{literalinclude}" in doc, page
        assert row not in doc, f"{page} holds a copy of the table"
    # what getting-started reads out of the answer is in it
    doc = (ROOT / "docs" / "getting-started.md").read_text(encoding="utf-8")
    says = doc[doc.index("What it says:"):]
    says = says[:says.index("\n\n")]
    figures = DECIMAL.findall(says)
    assert len(figures) >= 8
    assert [f for f in figures if f not in text] == []


def timing(path: Path = TIMING) -> dict:
    """The figures of a timing table written by ``bench_study.py --write``: {figure: measured} and the header's
    command, commit and date."""
    text = path.read_text(encoding="utf-8")
    rows = dict(re.findall(r"^\| ([^|]+?) \| ([^|]+?) \|", text, re.M))
    head = " ".join(line for line in text.splitlines() if line.startswith("#"))
    when = re.search(r"(?:on|measured on) (\d{4}-\d\d-\d\d) at commit ([0-9a-f]{7,})", head)
    return {"rows": rows, "head": head, "date": when and when.group(1), "commit": when and when.group(2)}


def _figure(rows: dict, name: str, unit: str) -> float:
    return float(re.fullmatch(rf"([\d.]+) {unit}", rows[name]).group(1))


def test_the_readme_states_the_recorded_timing():
    """The README's timing of the main job (wall, CPU-seconds, peak, the date) is the one in study.txt, rounded."""
    rec = timing()
    assert "python benchmarks/bench_study.py --write" in rec["head"] and rec["commit"], rec["head"]
    rows = rec["rows"]
    wall = _figure(rows, "wall, end to end", "s")
    cpu = _figure(rows, "CPU, all processes (user+sys)", "s")
    peak = _figure(rows, "peak memory, the command and its workers", "MB")
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    said = re.search(r"\((\d+) s wall and (\d+) CPU-seconds on \d cores, ([\d.]+) GB peak, by "
                     r"`benchmarks/bench_study.py`", readme)   # its date and commit: in study.txt, not the README
    assert said, "the README's timing sentence is not where the test looks"
    assert said.groups() == (f"{wall:.0f}", f"{cpu:.0f}", f"{peak / 1000:.1f}"), said.groups()
    # the printout's closing line carries the same run's seconds
    assert re.search(rf"^wrote OUT/report.pdf .*\({wall:.0f} s\)$", (ROOT / "README.md").read_text(encoding="utf-8"),
                     re.M)
    doc = (ROOT / "docs" / "benchmarks" / "study.md").read_text(encoding="utf-8")
    assert "{literalinclude} tables/study.txt" in doc
    doc = (ROOT / "docs" / "getting-started.md").read_text(encoding="utf-8")
    assert "{literalinclude} benchmarks/tables/study.txt" in doc


def test_the_oven_self_heating_has_one_source():
    """The study's reference page includes the recorded oven self-heating and copies none of its rows."""
    text = OVEN.read_text(encoding="utf-8")
    assert re.search(r"python benchmarks/bench_study.py --write` on \d{4}-\d\d-\d\d at commit [0-9a-f]{7}", text)
    doc = (ROOT / "docs" / "reference" / "study.md").read_text(encoding="utf-8")
    assert "{literalinclude} ../benchmarks/tables/oven_self_heating.txt" in doc
    rows = [line for line in text.splitlines() if line.startswith("| -40")]
    assert len(rows) == 3 and all(line not in doc for line in rows)
    for row in rows:   # no cell's figure typed into the page beside the table
        for cell in DECIMAL.findall(row):
            assert f"{cell} K" not in doc, cell


def _bench_study():
    spec = importlib.util.spec_from_file_location("bench_study", ROOT / "benchmarks" / "bench_study.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_bench_study_writes_what_the_docs_tests_read(tmp_path, monkeypatch):
    """``--write``'s writers on a made-up run: the timing table reads back with the figures it was given (so the
    README check above reads what the benchmark writes), and the answer file keeps the printout from the table's
    header to the last sentence."""
    bench = _bench_study()
    monkeypatch.setattr(bench, "_commit", lambda: "abcdef1")

    def scheme(nodes, rise, err):
        return {"max_rise_K": rise, "numerical_error": {"mesh": {"sensor_die_max_K": err,
                                                                 "answer_sensor_die_max_K": err / 4}},
                "self_heating_in_oven_K": {"chamber_C": [-40.0, 70.0], "gyro_x": [rise / 2, rise / 3]},
                "self_heating_solves": {"-40": {"model": "reduced", "check": {
                    "rounds": 2, "full_solves": 2, "cg_iterations": 28, "max_site_error_K": 0.0015, "tol_K": 0.01}}},
                "thermal": {"mesh": {"nodes": nodes}, "timings_s": {"steady_solve": 3.04, "transient_solve": 12.96},
                            "transient_check": {"accepted": True, "max_site_error_K": 0.0123},
                            "discretisation_error": {"timings_s": {"wall": 9.99}}}}
    summary = {"wall_s": 61.27, "schemes": {"air": scheme(1000, 36.364, 0.2191), "potted": scheme(1200, 15.8, 0.04)}}
    path = tmp_path / "study.txt"
    bench.write_timing(summary, 70.44, 123.46, 1999.6, "0.3 before, 0.9 after", path=path)
    rec = timing(path)
    assert rec["commit"] == "abcdef1" and re.fullmatch(r"\d{4}-\d\d-\d\d", rec["date"])
    rows = rec["rows"]
    assert (_figure(rows, "wall, end to end", "s"), _figure(rows, "CPU, all processes (user+sys)", "s"),
            _figure(rows, "peak memory, the command and its workers", "MB")) == (70.4, 123.5, 2000)
    assert rows["nodes (air / potted)"] == "1,000 / 1,200"
    assert rows["max rise"] == "36.36 / 15.80 K" and rows["of which the study"] == "61.3 s"
    assert rows["mesh-error estimate, largest at a sensor die"] == "0.219 / 0.040 K"
    assert rows["mesh-error estimate, the corrected answer's bound, largest at a sensor die"] == "0.055 / 0.010 K"
    assert "<= 0.1 K: PASS" in path.read_text()
    assert "<= 20 s: FAIL" in path.read_text() and "<= 2048 MB: PASS" in path.read_text()

    bench.write_oven(summary, tmp_path / "oven.txt")
    oven = (tmp_path / "oven.txt").read_text()
    assert "bench_study.py --write` on" in oven and "at commit abcdef1" in oven
    assert "| -40 °C | 18.18 |" in oven and "| 70 °C | 5.27 |" in oven and oven.count("reduced model, 2 round") == 2

    printed = "\n".join(["progress 1", "scheme   max rise [K]  ...", "air   36.36", "air: hot spot +36.4 K.",
                         "numerical error, air: ...", "wrote OUT/report.pdf (70 s)"])
    bench.write_answer(printed, tmp_path / "answer.txt")
    lines = (tmp_path / "answer.txt").read_text().splitlines()
    assert [line for line in lines if not line.startswith("#")] == printed.splitlines()[1:-1]
    assert any("bench_study.py --write" in line and "commit abcdef1" in line for line in lines)


def test_the_benchmark_pages_include_their_tables_and_copy_no_row():
    """Each benchmark page shows its recorded tables by including them: no row of an included table (the same
    row, or a row with the same three or more figures) is typed into the page beside it."""
    for page in sorted((ROOT / "docs" / "benchmarks").glob("*.md")):
        text = page.read_text(encoding="utf-8")
        page_rows = [line.strip() for line in text.splitlines() if line.startswith("|")]
        for inc in re.findall(r"\{literalinclude\} (tables/\S+\.txt)", text):
            table = (page.parent / inc).read_text(encoding="utf-8")
            for row in (line.strip() for line in table.splitlines() if line.startswith("|")):
                figures = DECIMAL.findall(row)
                if not figures:
                    continue
                assert not any(r == row or (len(figures) >= 3 and DECIMAL.findall(r) == figures) for r in page_rows), \
                    f"{page.name} copies a row of {inc}: {row}"


def test_a_benchmark_records_what_it_printed(tmp_path, monkeypatch):
    """``benchmarks/_record.py``: with ``--write`` the script runs without the flag and what it printed becomes
    the table, after a header with the command, the date and the commit; without it nothing is written."""
    import sys
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import _record
    monkeypatch.setattr(_record, "_commit", lambda: "abcdef1")
    monkeypatch.setattr(sys, "argv", ["bench_x.py"])
    seen = []

    def main():
        seen.append(list(sys.argv[1:]))
        print("| case | time |\n|---|---|\n| a | 1.25 s |  ")
        return 1   # a FAIL of the script's targets: still its figures

    assert _record.run(main, "x", "a made-up benchmark", argv=["--fast"], tables=tmp_path) == 1
    assert not (tmp_path / "x.txt").exists()
    assert _record.run(main, lambda args: "x_" + args[0].strip("-"), "a made-up benchmark",
                       argv=["--fast", "--write"], tables=tmp_path) == 1
    assert seen == [["--fast"], ["--fast"]]
    lines = (tmp_path / "x_fast.txt").read_text().splitlines()
    assert lines[0] == "# a made-up benchmark" and lines[1] == "# command: python benchmarks/bench_x.py --fast"
    assert re.match(r"# Written by `python benchmarks/bench_x.py --fast --write` on \d{4}-\d\d-\d\d at commit abcdef1;",
                    lines[2])
    body = [line for line in lines if not line.startswith("#")]
    assert body == ["", "| case | time |", "|---|---|", "| a | 1.25 s |"]


def _real_motion_rows() -> dict:
    """``tables/real_motion.txt`` (``bench_real_motion.py --write``): filter -> {run: [figures]}, each run's
    per-file figures, mean and (dev, cv) the mean and worst file over VQF's."""
    out, name = {}, None
    for line in (TABLES / "real_motion.txt").read_text(encoding="utf-8").splitlines():
        m = re.match(r"^([a-z_]+)?\s+(defaults|dev|cv)\s+([\d.\s]+)$", line)
        if m:
            name = m.group(1) or name
            out.setdefault(name, {})[m.group(2)] = [float(v) for v in m.group(3).split()]
    return out


def test_the_real_motion_table_has_one_source():
    """The real-motion table (defaults, dev and cross-validated means, x VQF, worst file x VQF) is the one
    ``bench_real_motion.py --write`` recorded: its page includes the file, the README links the page and copies
    none of its rows."""
    rec = _real_motion_rows()
    assert {"aekf", "kf", "gated", "vqf"} <= set(rec)
    doc = (ROOT / "docs" / "benchmarks" / "real_motion.md").read_text(encoding="utf-8")
    assert "{literalinclude} tables/real_motion.txt" in doc
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "docs/benchmarks/real_motion.md" in readme
    rows = [line for line in (TABLES / "real_motion.txt").read_text(encoding="utf-8").splitlines()
            if re.match(r"^\s*(aekf|kf|gated|vqf)\s", line)]
    assert rows and all(line.strip() not in readme for line in rows)


def test_the_readme_correlate_times_are_the_recorded_ones():
    """The README's `correlate` row (cold and warm wall times, a range as the host's speed drifts) is the range
    ``tables/correlation_speed.txt`` states, rounded to seconds."""
    text = " ".join((TABLES / "correlation_speed.txt").read_text(encoding="utf-8").split())
    rec = re.search(r"\(([\d.]+) s fast, [\d.]+-([\d.]+) s slow\); the warm run ([\d.]+)-([\d.]+) s", text)
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    said = re.search(r"three files at the default mesh: (\d+)-(\d+) s as this host's speed drifts, (\d+)-(\d+) s on "
                     r"the next run", readme)
    assert rec and said
    assert said.groups() == tuple(f"{float(v):.0f}" for v in rec.groups())


# ------------------------------------------------------------------ the reference pages
REFERENCE = ROOT / "docs" / "reference"
DATED = re.compile(r"dated record")
#: a paragraph, or an item of a list (a dated record is marked paragraph by paragraph, item by item)
PARAGRAPH = re.compile(r"\n\s*\n|\n(?=\s*(?:[-*]|\d+\.) )")


def current_text(page: Path) -> str:
    """What a page states as today's: its running text without the code and include blocks, without the
    paragraphs marked as a dated record and the table that follows such a paragraph."""
    text = re.sub(r"^```.*?^```", "", page.read_text(encoding="utf-8"), flags=re.S | re.M)
    return " ".join(" ".join(para for para, record in _units(text) if not record).split())


def _units(text: str):
    """(paragraph or list item, whether it belongs to a dated record): a paragraph that says "dated record", and
    the table or the list items that follow it directly."""
    after_record = False
    for para in PARAGRAPH.split(text):
        lead = para.lstrip()
        if DATED.search(para):
            after_record = True
        elif not (after_record and (lead.startswith("|") or re.match(r"(?:[-*]|\d+\.) ", lead))):
            after_record = False
        yield para, after_record


def _body(path: Path) -> list:
    return [line for line in path.read_text(encoding="utf-8").splitlines() if line.strip() and not line.startswith("#")]


def _written_by(path: Path, script: str) -> None:
    assert re.search(rf"Written by `python benchmarks/{script}[^`]* --write` on \d{{4}}-\d\d-\d\d at commit [0-9a-f]{{7}}",
                     path.read_text(encoding="utf-8")), f"{path.name} is not as {script} --write writes it"


def test_every_dated_record_says_when_and_at_which_commit():
    """A figure no script re-measures today stays on a reference or benchmark page only as a dated record: the
    paragraph says so, with the date and the commit of the run (a commit this repository has, where its history
    is at hand)."""
    import subprocess
    full_history = subprocess.run(["git", "rev-parse", "--is-shallow-repository"], cwd=ROOT, capture_output=True,
                                  text=True).stdout.strip() == "false"
    records = 0
    for page in sorted(REFERENCE.glob("*.md")) + sorted((ROOT / "docs" / "benchmarks").glob("*.md")):
        for para in PARAGRAPH.split(page.read_text(encoding="utf-8")):
            if not DATED.search(para):
                continue
            records += 1
            flat = " ".join(para.split())
            assert re.search(r"\d{4}-\d\d-\d\d", flat), f"{page.name}: a dated record without its date: {flat[:120]}"
            commits = re.findall(r"commits? ([0-9a-f]{7,40})\b", flat)
            assert commits, f"{page.name}: a dated record without its commit: {flat[:120]}"
            for commit in commits if full_history else ():
                found = subprocess.run(["git", "cat-file", "-e", f"{commit}^{{commit}}"], cwd=ROOT,
                                       capture_output=True)
                assert found.returncode == 0, f"{page.name}: no commit {commit}"
    assert records >= 10, records


def test_the_mesh_page_shows_the_recorded_mesh_error():
    """The mesh page's current figures of the discretisation error and its cost are the recorded compare's
    (included from compare_answer.txt and study.txt), not typed in."""
    doc = (REFERENCE / "mesh.md").read_text(encoding="utf-8")
    assert ":start-at: numerical error, air" in doc and "tables/compare_answer.txt" in doc
    assert "{literalinclude} ../benchmarks/tables/study.txt" in doc
    rows = {k: v for k, v in timing()["rows"].items() if k.startswith("mesh-error estimate")}
    assert len(rows) == 3 and all(f"| {k}" in TIMING.read_text(encoding="utf-8") for k in rows)
    now = current_text(REFERENCE / "mesh.md")
    lines = [line for line in answer() if line.startswith("numerical error")]
    figures = {f for line in lines for f in re.findall(r"[+]\d+\.\d+ K", line)}   # the default mesh's errors
    bounds = r"(\d+\.\d+ K) at the (?:sensor dies|hot spot)"                      # the corrected answer's bounds
    figures |= {f for line in lines for f in re.findall(bounds, line)}
    figures |= {f"{v} K" for row in rows.values() for v in DECIMAL.findall(row)}
    assert len(figures) >= 4 and [f for f in figures if f in now] == []


def test_the_study_page_types_no_recorded_figure():
    """The study page shows the recorded answer's real-motion and numerical-error lines by including them, and
    its running text restates none of their figures nor the reduced transient's recorded check."""
    doc = (REFERENCE / "study.md").read_text(encoding="utf-8")
    assert ":start-at: the same filters on real motion" in doc
    now = current_text(REFERENCE / "study.md")
    real = next(i for i, line in enumerate(answer()) if line.startswith("the same filters on real motion"))
    figures = set(DECIMAL.findall(" ".join(answer()[real + 1:real + 3])))
    figures |= {f for line in answer() if line.startswith("numerical error") for f in re.findall(r"\d+\.\d+ K", line)}
    figures |= {f"{v} K" for v in DECIMAL.findall(timing()["rows"]["reduced transient's check against the full model"])}
    assert len(figures) >= 8 and [f for f in figures if f in now] == []


def test_the_study_page_tuning_table_is_the_settings_file():
    """The flight's tuned vs default scores on the study page are those studies/attitude/filter_settings.toml records."""
    import tomllib
    settings = tomllib.loads((ROOT / "studies" / "attitude" / "filter_settings.toml").read_text(encoding="utf-8"))
    doc = (REFERENCE / "study.md").read_text(encoding="utf-8")
    table = doc[doc.index("Flight, tuned vs defaults [deg]"):]
    rows = re.findall(r"^\| (\w+) \| [^|]+ \| ([\d.]+) \| ([\d.]+) \|$", table[:table.index("\n\n", 200)], re.M)
    assert len(rows) == 9, rows
    for filt, tuned, default in rows:
        rec = settings["flight"][filt]
        assert (float(tuned), float(default)) == (round(rec["score"], 2), round(rec["default_score"], 2)), filt
    assert f"{settings['meta']['cpu_s']:.0f} CPU-s" not in current_text(REFERENCE / "study.md")


def test_the_layouts_page_includes_the_recorded_rises():
    """Both units' steady rises: bench_layouts.py --write's table, included; the page's text restates none."""
    table = TABLES / "layouts.txt"
    _written_by(table, "bench_layouts.py")
    rows = [line for line in _body(table) if re.match(r"^\| imu_", line)]
    assert [tuple(r.split("|")[1:3]) for r in rows] == [(f" {u} ", f" {s} ") for u in ("imu_reference", "imu_cardguide")
                                                       for s in ("air", "grease", "potted")]
    doc = (REFERENCE / "layouts.md").read_text(encoding="utf-8")
    assert "{literalinclude} ../benchmarks/tables/layouts.txt" in doc
    now = current_text(REFERENCE / "layouts.md")
    figures = {f for row in rows for cell in row.split("|")[5:9] for f in DECIMAL.findall(cell)}
    said = {f for f in figures for shown in (f, f"{float(f):.1f} K")   # a conductivity in W/m K is not a rise
            if re.search(rf"(?<![\w.]){re.escape(shown)}(?![\w.]| W)", now)}
    assert len(figures) >= 30 and said == set(), said


def test_the_commands_page_shows_the_recorded_solve():
    """The `solve` example is the printout bench_solve_example.py --write recorded, included; none typed in."""
    path = TABLES / "solve_example.txt"
    _written_by(path, "bench_solve_example.py")
    body = _body(path)
    assert body[0].startswith("$ imutherm solve") and any("max rise" in line for line in body)
    assert not any("%|" in line for line in body)   # no progress bar
    doc = (REFERENCE / "commands.md").read_text(encoding="utf-8")
    assert "{literalinclude} ../benchmarks/tables/solve_example.txt" in doc
    assert [line for line in body[1:] if line.strip() in doc] == []


def test_the_robustness_page_types_no_recorded_time():
    """The refusal times and the IMU side's measured costs are in their tables, which the page links."""
    now = current_text(REFERENCE / "robustness.md")
    assert "../benchmarks/refusals" in now and "../benchmarks/study_imu" in now
    times = set(re.findall(r"\d+\.\d+ s", " ".join(_body(TABLES / "refusals.txt"))))
    imu = set(re.findall(r"\d+(?:\.\d+)? (?:s|us|kB)", " ".join(_body(TABLES / "study_imu.txt"))))
    imu = {f.replace(" us", " µs") for f in imu if not f.startswith(("10 ", "3 ", "2 "))}   # not the cost constants
    assert len(times) >= 5 and len(imu) >= 4
    assert [f for f in times | imu if f in now] == []


def test_the_refusal_benchmark_refuses_every_case():
    """bench_refusals.py's recorded run: every case but the imports exited 2 (refused), none ran."""
    lines = [line for line in _body(TABLES / "refusals.txt") if re.search(r"exit \d|NOT REFUSED", line)]
    assert len(lines) >= 12 and "NOT REFUSED" not in " ".join(lines)
    assert all(" exit 2 " in line for line in lines if not line.startswith("imports only"))
    src = (ROOT / "benchmarks" / "bench_refusals.py").read_text(encoding="utf-8")
    assert '"--jobs", "1000", "--out"' not in src   # runs the study since the workers are capped at the cases


def _recorded_on(table: Path) -> str:
    """The date of a table's run (the first date of its header)."""
    head = " ".join(line for line in table.read_text(encoding="utf-8").splitlines() if line.startswith("#"))
    return re.search(r"\d{4}-\d\d-\d\d", head).group(0)


def test_benchmark_pages_say_which_recorded_run_their_text_reads():
    """A benchmark page's text that restates figures of a table the page includes (two or more in a paragraph)
    names the run it reads: its section says "as recorded YYYY-MM-DD", the date in that table's header, or the
    paragraph is a dated record of an older run. Re-recording a table changes its date, so this fails until its
    reading is redone."""
    flagged = 0
    for page in sorted((ROOT / "docs" / "benchmarks").glob("*.md")):
        text = page.read_text(encoding="utf-8")
        tables = [page.parent / inc for inc in re.findall(r"\{literalinclude\} (tables/\S+\.txt)", text)]
        figures = {t: set(DECIMAL.findall(" ".join(_body(t)))) for t in tables}
        body = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
        for section in re.split(r"^#+ ", body, flags=re.M):
            said = set(re.findall(r"(?i)as recorded (\d{4}-\d\d-\d\d)", " ".join(section.split())))
            for para, record in _units(section):
                if record or para.lstrip().startswith("|"):
                    continue
                for table, figs in figures.items():
                    if len([f for f in DECIMAL.findall(para) if f in figs]) >= 2:
                        flagged += 1
                        assert _recorded_on(table) in said, \
                            f"{page.name}: reads {table.name} without 'as recorded {_recorded_on(table)}': {para[:100]}"
    assert flagged >= 10, flagged
