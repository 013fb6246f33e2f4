"""Helpers shared by the subcommands: error handling and atomic output."""

from __future__ import annotations

import contextlib
import functools
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

from imutherm import InputError


def run_guarded(prog: str):
    """Decorate a subcommand ``main``: InputError -> one line on stderr, exit 2."""

    def wrap(func):
        @functools.wraps(func)
        def inner(argv=None):
            try:
                return func(argv)
            except InputError as exc:
                print(f"{prog}: error: {exc}", file=sys.stderr)
                return 2

        return inner

    return wrap


@contextlib.contextmanager
def atomic_outdir(out: str | os.PathLike):
    """Yield a temporary directory next to ``out``; move its files into ``out`` on success.

    On any exception nothing is written to ``out`` (no partial result files).
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        yield tmp
        out.mkdir(parents=True, exist_ok=True)
        for item in tmp.iterdir():
            target = out / item.name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target)
            os.replace(item, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_json(path: str | os.PathLike, data) -> None:
    """Write ``data`` as indented JSON (numpy scalars and arrays converted)."""
    import numpy as np

    def default(obj):
        if isinstance(obj, np.generic):
            return obj.item()
        if isinstance(obj, np.ndarray):
            return obj.tolist()
        raise TypeError(f"not JSON serialisable: {type(obj).__name__}")

    Path(path).write_text(json.dumps(data, indent=2, default=default) + "\n")
