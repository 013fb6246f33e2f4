"""Result files shared by the studies and the CLI: JSON with numpy values, CSV tables.

One writer per format, so every result file of the package has the same
conventions: JSON indented with NaN/inf written as ``null``; CSV with a header
row, ``time_s`` first where there is a time axis, temperatures in °C (the
site-temperature tables: :mod:`imutherm.site_table`).

The package's atomic file operations live here too, so there is one of each:

* :func:`atomic_write` (and :func:`atomic_write_bytes`) is the one way a single file is
  replaced: a temporary name beside it, then one rename; the file keeps the mode of the one it replaces
  (a new one gets 0666 less the umask, as any new file); :func:`stale_temporaries` finds what a killed
  writer left beside a path;
* :func:`move_staged` moves what was staged in a temporary folder into the output
  folder, each entry replacing its namesake in one rename;
* :func:`exchange_folders` swaps two whole folders in one step, the primitive of
  ``imutherm.cli._common.atomic_outdir``, which swaps whole result folders.
"""

from __future__ import annotations

import csv
import ctypes
import errno
import json
import math
import os
import re
import shutil
import stat
import tempfile
from pathlib import Path

import numpy as np


def plain(obj, *, finite: bool = True):
    """numpy scalars/arrays -> Python lists and numbers, dict keys -> str; with ``finite`` (default)
    non-finite floats -> None (JSON has no NaN)."""
    if isinstance(obj, dict):
        return {str(k): plain(v, finite=finite) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain(v, finite=finite) for v in obj]
    if isinstance(obj, np.ndarray):
        return plain(obj.tolist(), finite=finite)
    if isinstance(obj, np.generic):
        return plain(obj.item(), finite=finite)
    if finite and isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def current_umask() -> int:
    """The process's umask (read from /proc on Linux, so no other thread sees it changed)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)  # pragma: no cover (not Linux)
    os.umask(mask)
    return mask


def _temporary_prefix(path: Path, tmp_prefix: str | None) -> str:
    return f".{path.stem}." if tmp_prefix is None else tmp_prefix


def stale_temporaries(path: str | os.PathLike) -> list:
    """The temporary files :func:`atomic_write` makes beside ``path`` (``.STEM.XXXXXXXX.SUFFIX``, its default
    naming) that are there now. Only a writer that was killed leaves one behind: call this while holding a lock
    on ``path`` that every writer of it takes, and the ones found are stale."""
    path = Path(path)
    pattern = re.compile(re.escape(_temporary_prefix(path, None)) + r"[a-z0-9_]{8}" + re.escape(path.suffix) + "$")
    try:
        names = os.listdir(path.parent if str(path.parent) else ".")
    except OSError:
        return []
    return sorted(path.parent / n for n in names if pattern.match(n))


def atomic_write(path: str | os.PathLike, write, *, sync: bool = False, tmp_prefix: str | None = None) -> Path:
    """Replace ``path`` in one step: ``write(tmp)`` fills a temporary file beside it (same folder, so the
    same file system), which is then renamed over ``path``; on any error the temporary file is removed
    and ``path`` is untouched. With ``sync`` the temporary file is fsynced before the rename (the sweep's
    records, which a resume after a crash reads back). The temporary file is ``.STEM.XXXX.SUFFIX``, or
    ``TMP_PREFIXXXXX.SUFFIX`` with ``tmp_prefix`` (the cache's ``.tmp-``, which its eviction passes over);
    its name is unique (:func:`tempfile.mkstemp`), so concurrent writers of one path do not collide: the
    last rename wins. The file keeps the permissions of the one it replaces (a new one: 0666 less the umask,
    not the temporary's 0600). Returns ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        mode = stat.S_IMODE(os.stat(path).st_mode)
    except OSError:
        mode = 0o666 & ~current_umask()
    fd, tmp = tempfile.mkstemp(prefix=_temporary_prefix(path, tmp_prefix), suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, mode)
        if sync:
            fd = os.open(tmp, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def atomic_write_bytes(path: str | os.PathLike, data: bytes, *, sync: bool = False,
                       tmp_prefix: str | None = None) -> Path:
    """Replace ``path`` by the bytes ``data`` in one step (:func:`atomic_write`). Returns ``path``."""
    return atomic_write(path, lambda tmp: Path(tmp).write_bytes(data), sync=sync, tmp_prefix=tmp_prefix)


def move_staged(staged: str | os.PathLike, folder: str | os.PathLike) -> list[str]:
    """Move every entry of the staging folder ``staged`` into ``folder`` under its own name; returns the names.

    ``staged`` must be on the file system of ``folder`` (e.g. a temporary folder made inside it). Each
    entry replaces its namesake in ``folder`` in one rename, so a reader sees the old or the new file,
    never a half-written one; a run interrupted part-way leaves some entries new and the others old.
    A real folder of the same name (not a link to one) is deleted first, which is not atomic."""
    folder = Path(folder)
    names = []
    for item in Path(staged).iterdir():
        target = folder / item.name
        if target.is_dir() and not target.is_symlink():
            shutil.rmtree(target)
        os.replace(item, target)
        names.append(item.name)
    return names


def exchange_folders(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Swap two folders in one step (Linux ``renameat2(RENAME_EXCHANGE)``): True if done, False where the
    call is unsupported (not Linux, an older kernel, a file system without it); OSError on a real failure."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        func = libc.renameat2
    except (OSError, AttributeError):
        return False
    func.argtypes = (ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint)
    at_fdcwd, rename_exchange = -100, 2
    if func(at_fdcwd, os.fsencode(str(a)), at_fdcwd, os.fsencode(str(b)), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def write_json(path: str | os.PathLike, data, *, indent: int = 2, finite: bool = True) -> Path:
    """Write ``data`` as indented JSON, atomically (numpy values converted; with ``finite`` NaN/inf as
    null, else as JSON's NaN/Infinity extension, which :func:`json.load` reads back)."""
    text = json.dumps(plain(data, finite=finite), indent=indent) + "\n"
    return atomic_write(path, lambda tmp: Path(tmp).write_text(text))


def write_csv(path: str | os.PathLike, header, rows, fmt: str = "{:.6g}") -> None:
    """Write a CSV table: ``header`` (names) then ``rows`` (2-D array-like of numbers, formatted by ``fmt``)."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(header))
        for row in np.asarray(rows, float):
            w.writerow([fmt.format(v) for v in row])
