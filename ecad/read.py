"""``read_board(path)``: a board file of any supported format into a :class:`~imutherm.ecad.board.BoardDesign`.

KiCad ``.kicad_pcb`` (KiCad 4-9, :mod:`imutherm.ecad.kicad`) and IDF 3.0 ``.emn`` with its ``.emp`` library
beside it (:mod:`imutherm.ecad.idf`); the format is told by the file's first word, not only its suffix.
"""

from __future__ import annotations

from pathlib import Path

from imutherm import InputError

FORMATS = ".kicad_pcb (KiCad 4-9) or .emn (IDF 3.0, with its .emp library beside it)"


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
    from imutherm.ecad.idf import read_idf
    from imutherm.ecad.kicad import read_kicad

    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: board file not found; valid: a {FORMATS}")
    if path.is_dir():
        raise InputError(f"{path}: is a directory; give a board file: a {FORMATS}")
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError as exc:
        raise InputError(f"{path}: cannot read the board file ({exc.strerror or exc})") from None
    if not head.strip():
        raise InputError(f"{path}: the board file is empty; valid: a {FORMATS}")
    if b"\0" in head or head[:2] in (b"\x1f\x8b", b"PK"):
        kind = {b"\x1f\x8b": "gzip", b"PK": "zip"}.get(head[:2], "binary")
        raise InputError(f"{path}: a {kind} file, not a board file; valid: a {FORMATS} (unpack it first)"
                         if kind != "binary" else f"{path}: a binary file, not a board file; valid: a {FORMATS}")
    text = head.lstrip(b"\xef\xbb\xbf").lstrip()
    if text.startswith(b"(kicad_pcb") or path.suffix.lower() == ".kicad_pcb":
        if copper_layers is not None:
            raise InputError(f"{path}: --copper-layers is for IDF boards; a KiCad board states its own stack-up")
        return read_kicad(path)
    if text.upper().startswith(b".HEADER") or path.suffix.lower() == ".emn":
        if copper_layers is not None and not (isinstance(copper_layers, int) and 1 <= copper_layers <= 64):
            raise InputError(f"--copper-layers {copper_layers!r}: valid: 1..64")
        return read_idf(path) if copper_layers is None else read_idf(path, copper_layers=copper_layers)
    raise InputError(f"{path}: not a board file (it starts with {head[:20]!r}); valid: a {FORMATS}")
