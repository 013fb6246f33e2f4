"""The reference data a layout declares: the figures its model is set beside (``[reference_data]``).

A layout without the table has none: no paper's figures and no bench readings appear in its summary,
printout or report. The table::

    [reference_data]
    source = "our bench, 2026-11-03: thermocouples on the dies, 23 C lab"   # required: the citation
    measured = ["bench/air.csv", "bench/grease.csv"]   # measured CSVs (imutherm.measured format), beside the layout
    paper_figures = "liu2012"                          # the digest of Liu et al. 2012 (studies/paper_targets.toml)

At least one of ``measured`` and ``paper_figures``. ``paper_figures`` is the built-in ``liu2012`` or a TOML file
in the shape of ``studies/paper_targets.toml``; paths are relative to the layout file.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from imutherm import InputError

#: the built-in paper digests ``paper_figures`` may name
BUILTIN_PAPERS = {"liu2012": Path(__file__).resolve().parents[1] / "studies" / "paper_targets.toml"}
KEYS = ("source", "measured", "paper_figures")


@dataclass(frozen=True)
class ReferenceSpec:
    """A layout's reference data: ``source`` (citation), ``paper_figures`` (path or None), ``measured`` (paths)."""

    source: str
    paper_figures: str | None
    measured: tuple


def parse_reference(path: str, value) -> ReferenceSpec | None:
    """Check the ``[reference_data]`` table of the layout file ``path`` (None when absent)."""
    if value is None:
        return None
    where = f"{path}: [reference_data]"
    if not isinstance(value, dict):
        raise InputError(f"{where}: must be a table (source, measured, paper_figures), got {value!r}")
    extra = sorted(set(value) - set(KEYS))
    if extra:
        raise InputError(f"{where}: unknown field(s) {extra}; valid: {', '.join(KEYS)}")
    source = value.get("source")
    if not isinstance(source, str) or not source.strip():
        raise InputError(f"{where}: 'source' is required: who measured or published the figures, and where")
    base = Path(path).resolve().parent
    paper = value.get("paper_figures")
    if paper is not None:
        if not isinstance(paper, str):
            raise InputError(f"{where}: paper_figures must be 'liu2012' or a TOML file, got {paper!r}")
        paper = str(BUILTIN_PAPERS.get(paper) or _existing(base, paper, where, "paper_figures"))
    measured = value.get("measured", [])
    if isinstance(measured, str):
        measured = [measured]
    if not isinstance(measured, list) or not all(isinstance(m, str) for m in measured):
        raise InputError(f"{where}: measured must be a list of CSV files, got {measured!r}")
    measured = tuple(str(_existing(base, m, where, "measured")) for m in measured)
    if paper is None and not measured:
        raise InputError(f"{where}: declares nothing; give measured = [CSV files] and/or paper_figures")
    return ReferenceSpec(source.strip(), paper, measured)


def _existing(base: Path, name: str, where: str, field: str) -> Path:
    p = Path(name) if Path(name).is_absolute() else base / name
    if not p.is_file():
        raise InputError(f"{where}: {field} {name!r}: file not found (looked at {p})")
    return p
