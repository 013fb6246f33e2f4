"""The board-file readers are a registry (:data:`imutherm.ecad.read.READERS`): each format's suffixes, sniff and
read function drive ``read_board``'s detection, its errors and ``imutherm import``'s help."""

import argparse

import pytest

from imutherm import InputError
from imutherm.ecad import read as ecad_read


@pytest.fixture
def toy_format():
    """A format registered for one test (``.toyb`` files, first word ``TOYBOARD``), removed after it."""
    calls = []

    def read_toy(path, copper_layers=None):
        calls.append((path.name, copper_layers))
        return f"toy board {path.name}"

    ecad_read.register_reader("Toy 1.0", (".toyb",), lambda head: head.startswith(b"TOYBOARD"), read_toy,
                              note="this test's")
    try:
        yield calls
    finally:
        ecad_read.READERS.pop("Toy 1.0")


def test_the_registered_formats_are_kicad_then_idf():
    assert [(r.name, r.suffixes) for r in ecad_read.READERS.values()] == [("KiCad 4-9", (".kicad_pcb",)),
                                                                          ("IDF 3.0", (".emn",))]
    assert ecad_read.formats() == ".kicad_pcb (KiCad 4-9) or .emn (IDF 3.0, with its .emp library beside it)"
    with pytest.raises(ValueError, match="already registered"):
        ecad_read.register_reader("IDF 3.0", (".emn",), lambda head: False, lambda path, layers: None)


def test_a_registered_format_is_detected_by_its_sniff_and_by_its_suffix(toy_format, tmp_path):
    by_word = tmp_path / "board.txt"
    by_word.write_text("\ufeff  TOYBOARD 1\n")   # a BOM and white space before the first word
    by_suffix = tmp_path / "board.TOYB"
    by_suffix.write_text("anything\n")
    assert ecad_read.read_board(by_word) == "toy board board.txt"
    assert ecad_read.read_board(by_suffix, copper_layers=3) == "toy board board.TOYB"
    assert toy_format == [("board.txt", None), ("board.TOYB", 3)]
    other = tmp_path / "notes.txt"
    other.write_text("hello\n")
    with pytest.raises(InputError, match=r"not a board file .*; valid: a \.kicad_pcb \(KiCad 4-9\), \.emn "
                                         r"\(IDF 3\.0, with its \.emp library beside it\) or \.toyb \(Toy 1\.0, "
                                         r"this test's\)$"):
        ecad_read.read_board(other)


def test_the_kicad_and_idf_readers_keep_their_first_word_over_the_suffix(tmp_path, toy_format):
    """The built-in formats come first: a KiCad file named .toyb is read as KiCad (its first word), and the
    KiCad reader refuses the IDF-only --copper-layers as before."""
    pcb = tmp_path / "board.toyb"
    pcb.write_text("(kicad_pcb (version 20171130))\n")
    with pytest.raises(InputError, match="--copper-layers is for IDF boards"):
        ecad_read.read_board(pcb, copper_layers=2)
    assert toy_format == []


def test_the_import_help_lists_the_registered_formats(toy_format):
    from imutherm.cli.import_board import add_args

    parser = argparse.ArgumentParser()
    add_args(parser)
    action = next(a for a in parser._actions if a.dest == "board_file")
    assert action.help == f"the board file: {ecad_read.formats()}"
    assert ".toyb (Toy 1.0, this test's)" in action.help and ".kicad_pcb (KiCad 4-9)" in action.help
