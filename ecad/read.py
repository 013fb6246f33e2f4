"""``read_board(path)``: a board file of any supported format into a :class:`~imutherm.ecad.board.BoardDesign`.

The formats are registered readers (:data:`READERS`, :func:`register_reader`), each with its suffixes, its sniff
of the file's first bytes and its read function: KiCad ``.kicad_pcb`` (KiCad 4-9, :mod:`imutherm.ecad.kicad`)
and IDF 3.0 ``.emn`` with its ``.emp`` library beside it (:mod:`imutherm.ecad.idf`). The format is told by the
file's first word, not only its suffix; the errors and ``imutherm import``'s help list the formats from here
(:func:`formats`). A new format is its reader module and one :func:`register_reader` call below.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from imutherm import InputError


@dataclass(frozen=True)
class BoardReader:
    """One board-file format.

    name : the format in words (``KiCad 4-9``); suffixes : its file suffixes, lower case, the first one named in
    the help; sniff : ``(head: bytes) -> bool``, the file's first bytes (a BOM and leading white space stripped)
    are this format's; read : ``(path: Path, copper_layers: int | None) -> BoardDesign`` (InputError on bad
    input, ``copper_layers`` refused where the format states its own); note : what else the help says (a
    library file beside it)
    """

    name: str
    suffixes: tuple
    sniff: Callable[[bytes], bool]
    read: Callable
    note: str = ""

    def matches(self, path: Path, head: bytes) -> bool:
        """``path`` with first bytes ``head`` is this format's: its first word, or else its suffix."""
        return bool(self.sniff(head)) or path.suffix.lower() in self.suffixes


#: the board-file readers: name -> :class:`BoardReader`, tried in the order they were registered
READERS: dict = {}


def register_reader(name: str, suffixes, sniff: Callable[[bytes], bool], read: Callable, note: str = "") -> BoardReader:
    """Add a board-file format to :data:`READERS` (a name already there is refused: ValueError)."""
    if name in READERS:
        raise ValueError(f"board reader {name!r} is already registered")
    reader = BoardReader(name, tuple(s.lower() for s in suffixes), sniff, read, note)
    READERS[name] = reader
    return reader


def formats() -> str:
    """The registered formats in words, for the help and the errors: ``.kicad_pcb (KiCad 4-9) or .emn (...)``."""
    words = [f"{r.suffixes[0]} ({r.name}{', ' + r.note if r.note else ''})" for r in READERS.values()]
    return ", ".join(words[:-1]) + (" or " if len(words) > 1 else "") + words[-1]


def read_board(path: str | Path, copper_layers: int | None = None):
    """The board of ``path``; InputError in one line for anything that is not a readable board file.

    Parameters
    ----------
    path : str or Path, a KiCad ``.kicad_pcb`` or an IDF ``.emn`` file (its ``.emp`` library beside it)
    copper_layers : int or None, for an IDF board (which carries no stack-up): its copper layers of 35 um
        (default 4, assumed and said so); a KiCad board states its own, and giving them is refused

    Returns
    -------
    BoardDesign (:class:`~imutherm.ecad.board.BoardDesign`: outline [mm], stack-up, footprints, holes)

    Examples
    --------
    The open-hardware flight controller of the repository's ``examples/boards/`` (run from a clone):

    >>> import gzip, tempfile
    >>> from pathlib import Path
    >>> from imutherm.ecad.read import read_board
    >>> pcb = Path(tempfile.mkdtemp()) / "drone-fc.kicad_pcb"
    >>> _ = pcb.write_bytes(gzip.decompress(Path("examples/boards/drone-fc.kicad_pcb.gz").read_bytes()))
    >>> board = read_board(pcb)
    >>> print(f"{board.format}: {board.width_mm:.1f} x {board.height_mm:.1f} x {board.thickness_mm} mm, "
    ...       f"{board.copper_layers} copper layers, {len(board.footprints)} footprints")
    KiCad 5 (20171130): 50.0 x 50.0 x 1.6 mm, 2 copper layers, 78 footprints
    >>> read_board(Path("examples/boards/drone-fc.kicad_pcb.gz"))
    Traceback (most recent call last):
    ...
    imutherm.InputError: examples/boards/drone-fc.kicad_pcb.gz: a gzip file, not a board file; valid: ... (unpack it first)
    """
    path = Path(path)
    valid = formats()
    if not path.exists():
        raise InputError(f"{path}: board file not found; valid: a {valid}")
    if path.is_dir():
        raise InputError(f"{path}: is a directory; give a board file: a {valid}")
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError as exc:
        raise InputError(f"{path}: cannot read the board file ({exc.strerror or exc})") from None
    if not head.strip():
        raise InputError(f"{path}: the board file is empty; valid: a {valid}")
    if b"\0" in head or head[:2] in (b"\x1f\x8b", b"PK"):
        kind = {b"\x1f\x8b": "gzip", b"PK": "zip"}.get(head[:2], "binary")
        raise InputError(f"{path}: a {kind} file, not a board file; valid: a {valid} (unpack it first)"
                         if kind != "binary" else f"{path}: a binary file, not a board file; valid: a {valid}")
    text = head.lstrip(b"\xef\xbb\xbf").lstrip()
    for reader in READERS.values():
        if reader.matches(path, text):
            return reader.read(path, copper_layers)
    raise InputError(f"{path}: not a board file (it starts with {head[:20]!r}); valid: a {valid}")


def read_kicad_board(path: Path, copper_layers: int | None = None):
    """A KiCad board (:func:`imutherm.ecad.kicad.read_kicad`); it states its own stack-up: ``copper_layers`` refused."""
    from imutherm.ecad.kicad import read_kicad

    if copper_layers is not None:
        raise InputError(f"{path}: --copper-layers is for IDF boards; a KiCad board states its own stack-up")
    return read_kicad(path)


def read_idf_board(path: Path, copper_layers: int | None = None):
    """An IDF board (:func:`imutherm.ecad.idf.read_idf`) with ``copper_layers`` of 35 um (1..64; None: its default)."""
    from imutherm.ecad.idf import read_idf

    if copper_layers is not None and not (isinstance(copper_layers, int) and 1 <= copper_layers <= 64):
        raise InputError(f"--copper-layers {copper_layers!r}: valid: 1..64")
    return read_idf(path) if copper_layers is None else read_idf(path, copper_layers=copper_layers)


register_reader("KiCad 4-9", (".kicad_pcb",), lambda head: head.startswith(b"(kicad_pcb"), read_kicad_board)
register_reader("IDF 3.0", (".emn",), lambda head: head.upper().startswith(b".HEADER"), read_idf_board,
                note="with its .emp library beside it")
