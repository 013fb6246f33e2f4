"""The answer of ``imutherm compare`` has one source: ``docs/benchmarks/tables/compare_answer.txt``, written by
``python benchmarks/bench_study.py --write`` from what the command printed. The docs pages include it (so they
cannot show another table), the README's copy (a GitHub page cannot include a file) must be the same, and the
figures the getting-started page reads out of it must be in it.

(The gallery's stated figures are held to what the examples print in tests/test_gallery.py.)"""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ANSWER = ROOT / "docs" / "benchmarks" / "tables" / "compare_answer.txt"
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
