"""Helpers shared by the subcommands: error handling and atomic output."""

from __future__ import annotations

import contextlib
import fcntl
import functools
import hashlib
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

from imutherm import ConvergenceError, InputError
from imutherm.io import exchange_folders as _exchange  # the one-step folder swap (a test replaces it)
from imutherm.io import current_umask as _umask
from imutherm.io import move_staged
from imutherm.io import write_json  # noqa: F401  (re-exported for the subcommands)

# The commands draw into files only, never on a screen (and may run without a display): matplotlib's
# non-interactive backend unless the user chose one. Set here, where every subcommand starts, not at
# import of ``imutherm.reports`` (that would force it on scripts and notebooks that import the drawing code).
os.environ.setdefault("MPLBACKEND", "Agg")

#: the field files ``imutherm solve`` writes: ``field.vtu``, ``field.pvd`` and the series ``field_0000.vtu`` ...
FIELD_FILES = r"field(\.vtu|\.pvd|_\d{4,}\.vtu)"


#: exit status of bad input (InputError) or a file-system error (OSError), as argparse's own refusals
EXIT_BAD_INPUT = 2
#: exit status of a solve that did not converge (ConvergenceError)
EXIT_NOT_CONVERGED = 3

#: longest error line printed [characters]; the rest is cut (a value quoted in full could be megabytes)
MAX_MESSAGE_CHARS = 1000


def _one_line(text) -> str:
    line = " ".join(str(text).split())
    if len(line) > MAX_MESSAGE_CHARS:
        line = f"{line[:MAX_MESSAGE_CHARS]}... ({len(line) - MAX_MESSAGE_CHARS} more characters)"
    return line


def run_guarded(prog: str):
    """Decorate a subcommand ``main``: one line on stderr instead of a traceback.

    InputError (bad input) and OSError (file system) -> exit status 2; ConvergenceError (a solve that did
    not converge or diverged: not bad input, though the input is its likely cause) -> exit status 3
    (:data:`EXIT_NOT_CONVERGED`); KeyboardInterrupt -> exit status 130. The ``--out`` lock taken by
    :func:`check_outdir` is released when ``main`` returns.
    """

    def wrap(func):
        @functools.wraps(func)
        def inner(argv=None):
            held = set(_LOCKS)
            try:
                return func(argv)
            except (InputError, OSError) as exc:
                print(f"{prog}: error: {_one_line(exc)}", file=sys.stderr)
                return EXIT_BAD_INPUT
            except ConvergenceError as exc:
                print(f"{prog}: not converged: {_one_line(exc)}", file=sys.stderr)
                return EXIT_NOT_CONVERGED
            except KeyboardInterrupt:
                print(f"{prog}: interrupted", file=sys.stderr)
                return 130
            finally:
                for key in set(_LOCKS) - held:
                    _release(key)

        return inner

    return wrap


# ------------------------------------------------------------------ the --out lock
#: resolved --out -> open lock file (an flock held by this process)
_LOCKS: dict = {}


def _lock_path(real: Path) -> Path:
    """The lock file of a resolved ``--out``: in a per-user folder of the system temp dir, named by a hash of
    the path (so it exists before ``--out`` or its parents do, and nothing is left beside the results).
    Removed when the run ends; a killed run leaves its few bytes, and its lock is gone with the process."""
    folder = Path(tempfile.gettempdir()) / f"imutherm-locks-{os.getuid() if hasattr(os, 'getuid') else 0}"
    folder.mkdir(mode=0o700, exist_ok=True)
    return folder / (hashlib.sha1(os.fsencode(str(real))).hexdigest()[:20] + ".lock")


def _acquire(real: Path, out, option: str) -> None:
    key = str(real)
    if key in _LOCKS:
        return
    path = _lock_path(real)
    while True:
        fh = open(path, "a+")
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.seek(0)
            holder = fh.read().strip() or "unknown"
            fh.close()
            raise InputError(f"{option} {out} is being written by another imutherm run (pid {holder}, lock {path}); "
                             f"wait for it to finish or give another {option}") from None
        try:  # the holder before us may have removed the file between our open and our flock: lock it anew
            same = os.stat(path).st_ino == os.fstat(fh.fileno()).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        fh.close()
    fh.seek(0)
    fh.truncate()
    fh.write(f"{os.getpid()}\n")
    fh.flush()
    _LOCKS[key] = fh


def _release(key: str) -> None:
    fh = _LOCKS.pop(key, None)
    if fh is not None:
        with contextlib.suppress(OSError):  # removed while still held, so no lock files pile up
            os.unlink(fh.name)
        fh.close()  # closing the file drops the flock (the kernel drops it too if the process is killed)


def _probe_writable(folder: Path, out, option: str) -> None:
    """Create and remove a probe file in ``folder``; InputError naming ``option`` if that fails."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".imutherm-probe-", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise InputError(f"{option} {out}: cannot write in {folder} ({exc.strerror or exc}); "
                         f"give a writable directory") from None


def lock_output_file(out: str | os.PathLike, option: str = "--out") -> Path:
    """Lock the output file ``out`` for this run (as :func:`check_outdir` locks a folder: an flock, released when
    the subcommand returns or the process dies); return it resolved. A second run writing the same file is
    refused naming the first one's pid."""
    real = Path(os.path.realpath(out))
    _acquire(real, out, option)
    return real


def check_outdir(out: str | os.PathLike, option: str = "--out") -> Path:
    """Check ``out`` before any work and lock it for this run; return it resolved (symlinks followed).

    InputError unless ``out`` is a non-empty path that is a directory or can be created as one, writable
    (a probe file is created and removed in it or in its nearest existing ancestor), and not being written
    by another imutherm run (an flock, released when the subcommand returns or the process dies).
    """
    if not str(out).strip():
        raise InputError(f"{option} is empty; give a directory path")
    path = Path(out)
    real = Path(os.path.realpath(path))
    if real.exists() and not real.is_dir():
        raise InputError(f"{option} {out} exists and is not a directory; give a directory or a new path")
    for parent in (real, *real.parents):  # the nearest existing ancestor must be a writable directory
        if parent.exists():
            if not parent.is_dir():
                raise InputError(f"{option} {out}: {parent} is not a directory; give a directory or a new path")
            _probe_writable(parent, out, option)
            break
    _acquire(real, out, option)
    return real


# ------------------------------------------------------------------ atomic output
#: name part of the temporary folders beside --out (``.NAME.imutherm-XXXX``)
_TMP_TAG = ".imutherm-"
#: a backup of the old set, only made where the atomic exchange of two folders is unavailable
_OLD_TAG = ".imutherm-old-"


def _normalise_modes(folder: Path) -> None:
    """Files 0666 and folders 0777 less the umask (0644 / 0755 with the usual 022), whatever wrote them."""
    mask = _umask()
    for root, dirs, files in os.walk(folder):
        for d in dirs:
            os.chmod(os.path.join(root, d), 0o777 & ~mask)
        for f in files:
            p = os.path.join(root, f)
            if not os.path.islink(p):
                os.chmod(p, 0o666 & ~mask)


def pause_for_test(stage: str) -> None:
    """Test-only hook: with ``IMUTHERM_TEST_PAUSE=STAGE`` (``solving``, ``written``, ``swap``, ``swapped``,
    ``old-moved``, ``import-written``) say so on stderr and sleep ``IMUTHERM_TEST_PAUSE_S`` seconds (default 30)
    there, so a test can kill the process at that point (before the solve, in the final move, or with an
    import's temporary written). Unset in normal use."""
    if os.environ.get("IMUTHERM_TEST_PAUSE") == stage:
        print(f"imutherm: test pause at {stage}", file=sys.stderr, flush=True)
        time.sleep(float(os.environ.get("IMUTHERM_TEST_PAUSE_S", "30")))


_test_pause = pause_for_test  # the name the folder moves call (a test replaces it)


def _recover(real: Path) -> None:
    """Tidy what a killed run left beside ``real`` (called holding its lock).

    If ``real`` is missing and a backup ``.NAME.imutherm-old-*`` exists (a run killed between its two renames
    where the atomic exchange is unavailable), the backup, a complete earlier set, is renamed back first.
    Then the unfinished or replaced sets in ``.NAME.imutherm-*`` beside it are deleted.
    """
    parent, name = real.parent, real.name
    if not parent.is_dir():
        return
    try:
        leftovers = sorted((p for p in parent.iterdir() if p.name.startswith(f".{name}{_TMP_TAG}")),
                           key=lambda p: p.stat().st_mtime)
    except OSError:
        return
    if not real.exists():
        olds = [p for p in leftovers if p.name.startswith(f".{name}{_OLD_TAG}")]
        if olds:
            os.rename(olds[-1], real)
            leftovers.remove(olds[-1])
    for p in leftovers:
        shutil.rmtree(p, ignore_errors=True)
    if real.is_dir():
        for p in real.iterdir():
            if p.name.startswith(_TMP_TAG) and p.is_dir():
                shutil.rmtree(p, ignore_errors=True)


def _can_swap(real: Path) -> bool:
    """Whether ``real`` may be replaced as a whole folder: it holds only files (no sub-folders), is not a
    mount point, not the working directory or one of its ancestors, and its parent is writable."""
    if not real.exists():
        return True
    try:
        cwd = Path.cwd().resolve()
        if real == cwd or real in cwd.parents or os.path.ismount(real) or not os.access(real.parent, os.W_OK):
            return False
        entries = list(os.scandir(real))
    except OSError:
        return False
    return len(entries) <= 10_000 and not any(e.is_dir(follow_symlinks=False) for e in entries)


@contextlib.contextmanager
def atomic_outdir(out: str | os.PathLike, stale: str | None = None):
    """Yield an empty temporary folder; on success its files become ``out``, else ``out`` is untouched.

    ``out`` is resolved first (a symlink: its target is replaced, the link kept) and locked for the run
    (see :func:`check_outdir`). The temporary folder ``.NAME.imutherm-XXXX`` is created beside the
    resolved ``out``, on its file system. On success:

    * files already in ``out`` that the new set does not write are carried over (hard links, copies where
      links fail) except those whose whole name matches ``stale`` (a regular expression of names the
      command writes, e.g. :data:`FIELD_FILES`: ``field_0012.vtu`` of a longer earlier series goes);
    * modes are set to 0666/0777 less the umask;
    * the new folder and ``out`` are exchanged in one ``renameat2(RENAME_EXCHANGE)`` call, then the old
      set is deleted. A run killed at any point leaves ``out`` holding the complete old or the complete
      new set; at most a hidden ``.NAME.imutherm-XXXX`` folder beside it (unfinished new set, or the
      replaced old one) remains, which the next run into ``out`` deletes. Where the exchange is
      unsupported, ``out`` is renamed to ``.NAME.imutherm-old-XXXX`` and the new folder into place: a kill
      between the two leaves ``out`` missing and the old set in that backup, which the next run (or the
      user, by renaming it) puts back.

    An ``out`` that cannot be swapped whole (it holds sub-folders, is a mount point or the working
    directory) gets the new files moved in one by one instead (each file replaced in one step, stale
    files deleted after all new ones are in place); the temporary folder is then ``out/.imutherm-XXXX``.
    """
    locked_before = bool(str(out).strip()) and os.path.realpath(out) in _LOCKS
    real = check_outdir(out)
    try:
        _recover(real)
        swap = _can_swap(real)
        if swap:
            real.parent.mkdir(parents=True, exist_ok=True)
            tmp = Path(tempfile.mkdtemp(prefix=f".{real.name}{_TMP_TAG}", dir=real.parent))
        else:
            tmp = Path(tempfile.mkdtemp(prefix=_TMP_TAG, dir=real))
        try:
            yield tmp
            _normalise_modes(tmp)
            _test_pause("written")
            if swap:
                _swap_in(tmp, real, stale)
            else:
                _move_in(tmp, real, stale)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    finally:
        if not locked_before:  # a lock taken here, not by the command's check_outdir, ends here
            _release(str(real))


def _swap_in(tmp: Path, real: Path, stale: str | None) -> None:
    if not real.exists():
        os.chmod(tmp, 0o777 & ~_umask())
        os.rename(tmp, real)
        return
    new = {p.name for p in tmp.iterdir()}
    for entry in os.scandir(real):
        if entry.name in new or (stale is not None and re.fullmatch(stale, entry.name)):
            continue
        try:
            os.link(entry.path, tmp / entry.name, follow_symlinks=False)
        except OSError:
            shutil.copy2(entry.path, tmp / entry.name, follow_symlinks=False)
    shutil.copymode(real, tmp)
    _test_pause("swap")
    if _exchange(tmp, real):
        _test_pause("swapped")  # tmp now holds the old set
        shutil.rmtree(tmp, ignore_errors=True)
        return
    backup = real.with_name(f".{real.name}{_OLD_TAG}{os.getpid()}-{time.time_ns()}")
    os.rename(real, backup)
    _test_pause("old-moved")
    os.rename(tmp, real)
    shutil.rmtree(backup, ignore_errors=True)


def _move_in(tmp: Path, real: Path, stale: str | None) -> None:
    new = set(move_staged(tmp, real))
    if stale is not None:  # only after the whole new set is in place
        for old in real.iterdir():
            if old.name not in new and re.fullmatch(stale, old.name) and (old.is_file() or old.is_symlink()):
                old.unlink()


def in_background(fn, *args):
    """Start ``fn(*args)`` in a forked child process beside the caller; returns ``wait()``, which waits for it
    and raises OSError if it failed (its traceback is on stderr). The child inherits the caller's memory:
    nothing is pickled. Where there is no fork, ``fn`` runs at once and ``wait()`` returns at once."""
    import multiprocessing

    if "fork" not in multiprocessing.get_all_start_methods():
        fn(*args)
        return lambda: None
    proc = multiprocessing.get_context("fork").Process(target=fn, args=args, daemon=True)
    proc.start()

    def wait():
        proc.join()
        if proc.exitcode != 0:
            raise OSError(f"{getattr(fn, '__name__', fn)} failed in its process (exit status {proc.exitcode})")

    return wait


def help_text(doc: str | None) -> str:
    """A module docstring as ``--help`` text: without the reStructuredText markup (double backquotes, roles)."""
    text = re.sub(r":(?:func|class|mod|data|meth|attr):`~?([^`]+)`", r"\1", doc or "")
    return text.replace("``", "")
