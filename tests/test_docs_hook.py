"""The docs' docstring hook (docs/_ext/plain_docstrings.py) changes only the markup of the plain-text
docstrings: the words stay, aligned field lists become bullets, ``|x|`` is escaped, literal blocks and
numpydoc parameter sections are left as they are."""

import importlib.util
from pathlib import Path

HOOK = Path(__file__).resolve().parents[1] / "docs" / "_ext" / "plain_docstrings.py"
spec = importlib.util.spec_from_file_location("plain_docstrings", HOOK)
hook = importlib.util.module_from_spec(spec)
spec.loader.exec_module(hook)


def words(lines):
    return " ".join(" ".join(lines).replace("- ", " ").replace("``", "").replace("\\|", "|").split())


def test_field_lines_become_bullets_with_the_same_words():
    doc = ["Parameters of a filter.", "", "a : float [m/s^2]   gate threshold on max ||f| - g| in the",
           "                    window", "q : float [1/s]     process noise", "", "After the list."]
    out = hook.rewrite(doc)
    assert out[:2] == ["Parameters of a filter.", ""]
    assert out[2] == r"- ``a`` : float [m/s^2]   gate threshold on max \|\|f\| - g\| in the window"
    assert out[3] == "- ``q`` : float [1/s]     process noise"
    assert out[-1] == "After the list."
    assert words(out) == words(doc)


def test_literal_blocks_and_numpydoc_sections_are_kept():
    doc = ["Summary line.", "", "Formula::", "", "    |a| = b", "", "Parameters", "----------",
           "x : float [m]", "    The length |x|."]
    out = hook.rewrite(doc)
    assert "    |a| = b" in out                                 # a literal block: no escaping
    assert out[out.index("Parameters"):] == ["Parameters", "----------", "x : float [m]", r"    The length \|x\|."]


def test_a_summary_that_opens_a_literal_block_survives_numpydoc_dedent():
    out = hook.rewrite(["Intensities [m/s]::", "", "s = 0.1 W", "L = h"])
    assert out == ["Intensities [m/s]:", "", "::", "", "    s = 0.1 W", "    L = h"]


def test_unknown_headings_become_rubrics():
    out = hook.rewrite(["Summary.", "", "Profiles", "--------", "``static``  at rest."], module=True)
    assert ".. rubric:: Profiles" in out and "- ``static`` : at rest." in out


def test_examples_sections_are_kept_as_written():
    doc = ["Summary.", "", "Examples", "--------", "A wrapped sentence of prose", "    that is not joined here.", "",
           ">>> f(1,", "...   2) | 3", "  4", "x : 1"]
    out = hook.rewrite(doc)
    assert out == doc
