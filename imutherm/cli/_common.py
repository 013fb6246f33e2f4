"""Helpers shared by the subcommands: error handling and atomic output."""

from __future__ import annotations

import contextlib
import functools
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

from imutherm import InputError
from imutherm.io import write_json  # noqa: F401  (re-exported for the subcommands)

#: the field files ``imutherm solve`` writes: ``field.vtu``, ``field.pvd`` and the series ``field_0000.vtu`` ...
FIELD_FILES = r"field(\.vtu|\.pvd|_\d{4,}\.vtu)"


def _one_line(text) -> str:
    return " ".join(str(text).split())


def run_guarded(prog: str):
    """Decorate a subcommand ``main``: one line on stderr instead of a traceback.

    InputError (bad input) and OSError (file system) -> exit status 2;
    KeyboardInterrupt -> exit status 130.
    """

    def wrap(func):
        @functools.wraps(func)
        def inner(argv=None):
            try:
                return func(argv)
            except (InputError, OSError) as exc:
                print(f"{prog}: error: {_one_line(exc)}", file=sys.stderr)
                return 2
            except KeyboardInterrupt:
                print(f"{prog}: interrupted", file=sys.stderr)
                return 130

        return inner

    return wrap


def check_outdir(out: str | os.PathLike, option: str = "--out") -> None:
    """InputError unless ``out`` is a directory or can be created as one.

    Called right after argument parsing, so a bad ``--out`` fails before any work.
    """
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise InputError(f"{option} {out} exists and is not a directory; give a directory or a new path")
    for parent in path.absolute().parents:  # the nearest existing ancestor must be a directory
        if parent.exists():
            if not parent.is_dir():
                raise InputError(f"{option} {out}: {parent} is not a directory; give a directory or a new path")
            break


@contextlib.contextmanager
def atomic_outdir(out: str | os.PathLike, stale: str | None = None):
    """Yield a temporary directory next to ``out``; move its files into ``out`` on success.

    On any exception nothing is written to or removed from ``out`` (no partial
    result files). ``stale``: regular expression of file names the command
    writes (e.g. :data:`FIELD_FILES`); on success, files in ``out`` whose whole
    name matches are removed before the new files are moved in, so no output
    of an earlier run is left behind (e.g. ``field_0012.vtu`` of a longer series).
    """
    out = Path(out)
    check_outdir(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        yield tmp
        out.mkdir(parents=True, exist_ok=True)
        if stale is not None:
            for old in out.iterdir():
                if re.fullmatch(stale, old.name) and (old.is_file() or old.is_symlink()):
                    old.unlink()
        for item in tmp.iterdir():
            target = out / item.name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target)
            os.replace(item, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
