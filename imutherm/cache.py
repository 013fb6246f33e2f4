"""A disk cache of expensive model products (reduced models, full-model re-runs), keyed by their content.

A value is stored under the SHA-256 of a canonical form of everything it depends on (:func:`key_of`:
dataclasses field by field, arrays by their bytes, floats exactly) and of :data:`CODE_VERSION`, a hash of
the source of the modules that compute the models and of the numeric libraries' versions (numpy, scipy, pyamg): a change of the layout, the scheme, the ambient, the
mesh, the model options, the knob set or the code is a different key, so a stale entry is never read.

* Folder: ``$IMUTHERM_CACHE_DIR`` if set, else the user cache folder (``platformdirs``), ``.../imutherm``.
* Switch: ``$IMUTHERM_CACHE`` ``0``, ``off``, ``no`` or ``false`` turns the cache off (nothing read or written),
  as each command's ``--no-cache`` does for one run.
* Size limit: ``$IMUTHERM_CACHE_MB`` (default :data:`DEFAULT_LIMIT_MB`); after each write the least
  recently used entries (a hit refreshes an entry's time) are removed until the folder fits.
* Interrupted writes and concurrent runs: a value is written to a temporary file in the same folder and
  renamed over its name (atomic), so a reader sees a whole entry or none; two runs writing the same key
  write the same bytes. Each entry carries its key and a checksum of its payload: a truncated, corrupted
  or foreign file is a miss (deleted, rebuilt), never a traceback. Entries are pickles: the folder is the
  user's own, like any cache of Python objects.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import os
import pickle
from pathlib import Path

import numpy as np

from imutherm.io import atomic_write_bytes

#: environment variable naming the cache folder (tests and CI point it at a temporary folder)
CACHE_ENV = "IMUTHERM_CACHE_DIR"
#: environment variable giving the size limit [MB]
LIMIT_ENV = "IMUTHERM_CACHE_MB"
DEFAULT_LIMIT_MB = 2048.0
_MAGIC = b"IMUTHERM-CACHE-1\n"
_SUFFIX = ".pkl"
#: name start of an entry being written (:func:`imutherm.io.atomic_write_bytes`); eviction passes over it
_TMP_PREFIX = ".tmp-"


def _package_dir(pkg: str) -> Path:
    """The folder of the subpackage ``imutherm.<pkg>`` (found, not imported: its ``__init__`` does not run)."""
    import importlib.util

    spec = importlib.util.find_spec(f"imutherm.{pkg}")
    if spec is None or not spec.submodule_search_locations:   # pragma: no cover - every subpackage is installed
        return Path(__file__).resolve().parent.parent / pkg
    return Path(next(iter(spec.submodule_search_locations))).resolve()


def source_version(files) -> str:
    """SHA-256 (16 hex) of the named source files, each ``(subpackage, path inside it)``, e.g.
    ``("studies", "thermal/thermal_study.py")``; a folder's path (``("unit", "effects")``) takes its ``.py`` and
    ``.toml`` files, recursively. Files are read, never imported (the key of a cached value stays cheap to compute)."""
    h = hashlib.sha256()
    for pkg, rel in files:
        base = _package_dir(pkg) if pkg != "imutherm" else Path(__file__).resolve().parent
        target = base / rel if rel else base
        found = ([target] if target.is_file() else
                 sorted(f for ext in ("*.py", "*.toml") for f in target.rglob(ext) if "__pycache__" not in f.parts))
        for f in found:
            h.update(f"{pkg}/{f.relative_to(base).as_posix()}".encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


#: the libraries whose numerics a cached model's numbers depend on (their installed versions join the key)
NUMERIC_LIBRARIES = ("numpy", "scipy", "pyamg")


def _library_versions() -> str:
    """``name=version`` of :data:`NUMERIC_LIBRARIES` (package metadata: nothing imported)."""
    from importlib import metadata

    out = []
    for name in NUMERIC_LIBRARIES:
        try:
            out.append(f"{name}={metadata.version(name)}")
        except metadata.PackageNotFoundError:   # pragma: no cover - every one is a dependency
            out.append(f"{name}=?")
    return ",".join(out)


def _code_version() -> str:
    """SHA-256 (16 hex) of the source of the modules a cached model depends on (thermal, unit, geometry and
    layouts, their subfolders included, and the physical constants) and of the numeric libraries' versions."""
    src = source_version([(pkg, "") for pkg in ("thermal", "unit", "geometry", "layouts")]
                         + [("imutherm", "constants.py")])
    return hashlib.sha256(f"{src};{_library_versions()}".encode()).hexdigest()[:16]


#: the models' code version (changes with any change of their source)
CODE_VERSION = _code_version()


#: environment variable switching the cache off (``0``, ``off``, ``no``, ``false``; anything else: on)
ENABLE_ENV = "IMUTHERM_CACHE"


def enabled() -> bool:
    """False when ``$IMUTHERM_CACHE`` switches the cache off (``0``, ``off``, ``no``, ``false``)."""
    return os.environ.get(ENABLE_ENV, "").strip().lower() not in ("0", "off", "no", "false")


def cache_dir() -> Path:
    """The cache folder (``$IMUTHERM_CACHE_DIR`` or the user cache folder)."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env)
    import platformdirs
    return Path(platformdirs.user_cache_dir("imutherm", appauthor=False))


def limit_bytes() -> float:
    """The size limit [bytes] (``$IMUTHERM_CACHE_MB``, default :data:`DEFAULT_LIMIT_MB`)."""
    try:
        mb = float(os.environ.get(LIMIT_ENV, DEFAULT_LIMIT_MB))
    except ValueError:
        mb = DEFAULT_LIMIT_MB
    return mb * 1024 * 1024


def _canon(x):
    """A canonical, hashable form of ``x`` (dataclasses, mappings, sequences, arrays, numbers, strings)."""
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return (type(x).__qualname__,) + tuple((f.name, _canon(getattr(x, f.name))) for f in dataclasses.fields(x))
    if isinstance(x, dict):
        return ("dict",) + tuple(sorted((repr(_canon(k)), _canon(v)) for k, v in x.items()))
    if isinstance(x, (list, tuple)):
        return (type(x).__name__,) + tuple(_canon(v) for v in x)
    if isinstance(x, (set, frozenset)):
        return ("set",) + tuple(sorted(repr(_canon(v)) for v in x))
    if isinstance(x, np.ndarray):
        a = np.ascontiguousarray(x)
        if a.dtype == object:
            return ("ndo", a.shape, tuple(_canon(v) for v in a.ravel()))
        return ("nd", str(a.dtype), a.shape, hashlib.sha256(a.tobytes()).hexdigest())
    if isinstance(x, (float, np.floating)):
        return ("f", float(x).hex())
    if isinstance(x, (bool, int, np.integer, str, bytes, type(None))):
        return x.item() if isinstance(x, np.generic) else x
    if isinstance(x, os.PathLike):
        return ("path", os.fspath(x))
    if hasattr(x, "__dict__"):
        return (type(x).__qualname__,) + tuple(sorted((k, _canon(v)) for k, v in vars(x).items()))
    return (type(x).__qualname__, repr(x))


def key_of(kind: str, *parts) -> str:
    """The cache key (hex SHA-256) of a value of ``kind`` depending on ``parts`` and :data:`CODE_VERSION`."""
    return hashlib.sha256(repr((kind, CODE_VERSION, _canon(parts))).encode()).hexdigest()


def _path(key: str, folder: Path) -> Path:
    return folder / f"{key}{_SUFFIX}"


def load(key: str, folder: Path | None = None):
    """The value stored under ``key``, or None (a miss: absent, truncated, corrupted or another key's)."""
    return load_status(key, folder)[0]


def load_status(key: str, folder: Path | None = None) -> tuple:
    """(value or None, status): status ``hit``, ``absent`` (no entry) or ``unreadable`` (an entry that is
    truncated, corrupted, another key's or does not unpickle: deleted, so the caller rebuilds it)."""
    p = _path(key, folder or cache_dir())
    try:
        data = p.read_bytes()
    except OSError:
        return None, "absent"
    head = len(_MAGIC) + 64 + 64
    payload = memoryview(data)[head:]   # a view: the payload (tens of MB for a thermal case) is not copied
    ok = (len(data) > head and data.startswith(_MAGIC) and data[len(_MAGIC):len(_MAGIC) + 64] == key.encode()
          and hashlib.sha256(payload).hexdigest().encode() == data[len(_MAGIC) + 64:head])
    if ok:
        try:
            value = pickle.loads(payload)
        except Exception:   # a checksum-valid entry that does not unpickle (e.g. a class since renamed)
            ok = False
    if not ok:
        _remove(p)
        return None, "unreadable"
    try:
        os.utime(p)   # least recently *used*: a hit refreshes the entry
    except OSError:
        pass
    return value, "hit"


def store(key: str, value, folder: Path | None = None) -> Path | None:
    """Write ``value`` under ``key`` (temporary file + atomic rename), then evict to the size limit.

    Returns the entry's path, or None when the folder cannot be written or the value does not pickle (the run
    goes on uncached)."""
    folder = folder or cache_dir()
    head = len(_MAGIC) + 64 + 64
    buf = io.BytesIO()
    buf.write(_MAGIC + key.encode() + b"0" * 64)   # the payload's checksum written in below, once known
    try:
        pickle.dump(value, buf, protocol=pickle.HIGHEST_PROTOCOL)
    except (pickle.PicklingError, TypeError, AttributeError):   # a value that does not pickle: the run goes on
        return None
    entry = buf.getbuffer()   # the whole entry, not copied
    entry[head - 64:head] = hashlib.sha256(entry[head:]).hexdigest().encode()
    p = _path(key, folder)
    try:
        atomic_write_bytes(p, entry, tmp_prefix=_TMP_PREFIX)
    except OSError:
        return None
    evict(folder)
    return p


def evict(folder: Path | None = None, limit: float | None = None) -> list:
    """Remove the least recently used entries until the folder's entries fit ``limit`` [bytes]; their paths."""
    folder = folder or cache_dir()
    limit = limit_bytes() if limit is None else limit
    entries = []
    for p in folder.glob(f"*{_SUFFIX}"):
        if p.name.startswith(_TMP_PREFIX):   # another run's entry being written
            continue
        try:
            st = p.stat()
        except OSError:
            continue
        entries.append((st.st_mtime, st.st_size, p))
    total = sum(e[1] for e in entries)
    removed = []
    for _, size, p in sorted(entries, key=lambda e: e[0]):
        if total <= limit:
            break
        _remove(p)
        total -= size
        removed.append(p)
    return removed


def _remove(p: Path) -> None:
    try:
        p.unlink()
    except OSError:
        pass


def cached(kind: str, parts: tuple, build, *, use_cache: bool = True, progress=None):
    """``build()``, or its value stored under the key of (``kind``, ``parts``): (value, hit: bool).

    use_cache False (or ``$IMUTHERM_CACHE`` off, :func:`enabled`): build, neither read nor write.
    progress: callable(str) told of a hit, and of an entry that could not be read (rebuilt).
    """
    if not (use_cache and enabled()):
        return build(), False
    key = key_of(kind, *parts)
    value, status = load_status(key)
    if status == "hit":
        if progress:
            progress(f"{kind}: from the cache ({cache_dir()})")
        return value, True
    if status == "unreadable" and progress:
        progress(f"{kind}: the cache entry {key[:12]} could not be read: recomputed")
    value = build()
    store(key, value)
    return value, False
