"""The six shared real boards import as they are (issue 55): each with its powers file and its sensor site, the
fate of every footprint asserted, the unusual things it has said, and every cooling scheme built.

The boards are public open-hardware KiCad files copied unchanged into ``examples/boards/`` (sources and
licences: ``examples/boards/SOURCES.md``): KiCad 5, 7, 8 and 9, 39 to 244 footprints, 2 and 4 copper layers, a
notched and slotted CubeSat card, edge connectors, duplicate references, do-not-populate parts, mounting holes
with and without a library name. What a user gives: ``--powers`` (``examples/boards/<board>_powers.csv``, each
value with its datasheet source) and ``--site``; openuav's regulators by its electrical design. No heights:
every part's height comes from its footprint (a Height field), its name or the package tables, else it is
estimated by the stated rule and listed (:mod:`imutherm.ecad.heights`).
"""

from __future__ import annotations

import gzip
from collections import Counter
from pathlib import Path

import pytest

from imutherm.ecad.heights import is_estimated
from imutherm.ecad.read import read_board
from imutherm.ecad.to_layout import ImportOptions, import_board
from imutherm.ecad.user_tables import read_electrical, read_value_csv
from imutherm.geometry.build import build_geometry

BOARDS = Path(__file__).resolve().parents[1] / "examples" / "boards"
SITES = {"cube-main": ("U9", "probe"), "proves-fc-v4c": ("U7", "imu"), "proves-radio-stick": ("U18", "probe"),
         "unl-core-board": ("U5", "imu"), "openuav": ("U3", "imu"), "drone-fc": ("U2", "imu")}


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    """{board: ImportResult} of the six boards, each imported with its powers and site alone."""
    folder = tmp_path_factory.mktemp("shared-boards")
    out = {}
    for name, (ref, kind) in SITES.items():
        path = folder / f"{name}.kicad_pcb"
        path.write_bytes(gzip.decompress((BOARDS / f"{name}.kicad_pcb.gz").read_bytes()))
        electrical = read_electrical(BOARDS / "openuav_electrical.toml") if name == "openuav" else None
        opts = ImportOptions(powers=read_value_csv(BOARDS / f"{name}_powers.csv", "power_W"), sites={ref: kind},
                             electrical=electrical)
        out[name] = import_board(read_board(path), opts)
    return out


def _skipped(result) -> dict:
    """{reason: set of refs} of the skipped footprints."""
    out: dict = {}
    for d in result.decisions:
        if d.fate == "skipped":
            out.setdefault(d.reason, set()).add(d.footprint.ref)
    return out


def _notes(result, words: str) -> list:
    return [n for n in result.notes if words in n]


FATES = {  # board: (footprints, modelled, merged, skipped)
    "cube-main": (244, 47, 186, 11), "proves-fc-v4c": (151, 31, 93, 27), "proves-radio-stick": (70, 13, 45, 12),
    "unl-core-board": (39, 13, 19, 7), "openuav": (80, 9, 42, 29), "drone-fc": (78, 15, 59, 4)}


#: the parts on each board (modelled or merged) whose height no footprint, name or table gives: estimated
ESTIMATED = {"cube-main": {"U1", "U2", "U3", "U4"}, "proves-fc-v4c": set(), "proves-radio-stick": set(),
             "unl-core-board": set(), "openuav": set(), "drone-fc": {"D1"}}


@pytest.mark.parametrize("name", list(SITES))
def test_each_shared_board_has_a_height_for_every_part(imported, name):
    """No heights file: the custom TMC2209-LA footprints (no package in the name) and drone-fc's custom RGB LED
    are estimated, every other part of the six boards has a found height with its source."""
    r = imported[name]
    placed = [d for d in r.decisions if d.fate != "skipped"]
    assert all(d.height_mm and d.height_source for d in placed)
    assert {d.footprint.ref for d in placed if is_estimated(d.height_source)} == ESTIMATED[name]
    assert bool(ESTIMATED[name]) == any(n.startswith("ESTIMATED heights of") for n in r.notes)


@pytest.mark.parametrize("name", list(SITES))
def test_each_shared_board_imports_with_every_footprint_accounted_for(imported, name):
    r = imported[name]
    assert (len(r.decisions), r.count("modelled"), r.count("merged"), r.count("skipped")) == FATES[name]
    assert all(d.reason for d in r.decisions)
    given = read_value_csv(BOARDS / f"{name}_powers.csv", "power_W")
    power = {c.name: c.power_W for c in r.spec.components}
    assert sum(power[ref] for ref in given) == pytest.approx(sum(v for v, _ in given.values()))
    others = {ref: w for ref, w in power.items() if ref not in given and w > 0}
    # openuav's regulators dissipate what its electrical design says; no other board has a power not given
    assert (set(others) == {"U4", "U5", "U7"}) if name == "openuav" else not others
    for scheme in r.spec.schemes:
        build_geometry(r.spec, scheme)


def test_cube_main(imported):
    """KiCad 5, no stack-up, 244 footprints: four mounting holes and two logos all named REF**, DNP values, a
    micro-USB receptacle over the right edge."""
    r = imported["cube-main"]
    s = _skipped(r)
    assert s["marked do-not-populate (value 'DNP')"] == {"C66", "C67", "Y2"}
    assert s["mounting hole (a standoff is placed under it)"] == {"REF**_3", "REF**_4", "REF**_5", "REF**_6"}
    assert _notes(r, "duplicate references on the board: REF** (6 footprints), G*** (2 footprints)")
    assert _notes(r, "J10 at (147.30, 68.15) mm: its body overhangs the board's right edge by 0.65 mm")
    assert len([p for p in r.spec.parts if p.name.startswith("standoff")]) == 4
    assert {c.name for c in r.spec.components} >= {"U1", "U2", "U3", "U4", "U5", "U6", "U9", "J10"}


def test_proves_fc_v4c(imported):
    """KiCad 8, a non-default stack-up (1.626 mm, one 15.2 um inner copper), a notched outline with the
    micro-USB in its notch, two mounting holes without a library name, a DNI field, crossing fab outlines."""
    r = imported["proves-fc-v4c"]
    assert r.board.thickness_mm == pytest.approx(1.626) and r.board.copper_um == pytest.approx((35, 15.2, 35, 35))
    s = _skipped(r)
    assert s["mounting hole (a 3.2 mm hole without a body: a standoff is placed under it)"] == {"H1", "H2"}
    assert s["marked do-not-populate (field DNI = 'DNI')"] == {"U5"}
    assert len(s["test point (a bare pad)"]) == 8 and len(s["net tie / solder jumper (copper only)"]) == 11
    assert _notes(r, "J8 at (83.03, 59.05) mm: 14 % of its body lies over a notch or cut-out of the board outline")
    assert _notes(r, "J16's trimmed by 0.20 mm to meet J7's")


def test_proves_radio_stick(imported):
    """KiCad 9 layer numbering (F.Cu 0, B.Cu 2, In1.Cu 4, In2.Cu 6), a logo left outside the board, a
    regulator whose fab drawing is only a pin-1 dot (its body from the courtyard and pads)."""
    r = imported["proves-radio-stick"]
    assert r.board.copper_layers == 4 and {d.footprint.side for d in r.decisions} == {"top"}
    assert _skipped(r)["outside the board outline"] == {"G***"}
    u2 = next(d for d in r.decisions if d.footprint.ref == "U2")
    assert u2.fate == "modelled" and u2.body.width > 2.0 and u2.power_W == pytest.approx(0.05)


def test_unl_core_board(imported):
    r = imported["unl-core-board"]
    assert _skipped(r)["mounting hole (a standoff is placed under it)"] == {"H1", "H2", "H3", "H4"}
    assert _notes(r, "J4 at (11.28, 52.38) mm: its body overhangs the board's top edge by 2.45 mm")


def test_openuav_and_drone_fc_as_before(imported):
    """The two boards of issue 42 keep their fates (the 25 wire pads of openuav skipped, not mounting holes)."""
    ou, fc = imported["openuav"], imported["drone-fc"]
    assert len(_skipped(ou)["one pad and no body outline: a wire or test pad"]) == 25
    assert {c.name for c in ou.spec.components} == {"J99", "L1", "U1", "U2", "U3", "U4", "U5", "U6", "U7"}
    assert Counter(d.fate for d in fc.decisions if d.footprint.ref.startswith("H")) == Counter(skipped=4)


def test_the_import_command_says_which_file_gave_each_power(tmp_path, capsys):
    from imutherm.cli.import_board import main as import_main

    board = tmp_path / "unl-core-board.kicad_pcb"
    board.write_bytes(gzip.decompress((BOARDS / "unl-core-board.kicad_pcb.gz").read_bytes()))
    out = tmp_path / "unit.toml"
    assert import_main([str(board), "--powers", str(BOARDS / "unl-core-board_powers.csv"), "--site", "U5=imu",
                        "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "modelled U5     BNO055" in text and "0.041 W (unl-core-board_powers.csv line 4: BNO055 in NDOF" in text
    assert "powers: 0.071 W in all: 0.071 W from unl-core-board_powers.csv (3 parts)" in text
    assert "note: J4 at (11.28, 52.38) mm" in text
    assert "heights of the modelled and merged parts: 32 from the package tables" in text and "ESTIMATED" not in text
