"""Read a user's text file (layout TOML, temperature CSV) strictly: UTF-8 only, size-capped, one-line errors.

Every failure is an :class:`imutherm.InputError` naming the file and saying what
would be valid; nothing here raises UnicodeDecodeError or a bare OSError.
"""

from __future__ import annotations

import codecs
import os
from pathlib import Path

from imutherm import InputError

#: largest text input read [bytes]: 16 MiB. The reference layout is 12 kB and a temperature CSV of a
#: 10 000-step transient ~1 MB, so this is far above any real input and far below what would exhaust memory.
MAX_TEXT_BYTES = 16 * 2**20

#: longest piece of user text quoted in an error message [characters]
MAX_QUOTE_CHARS = 200


def quote(text, limit: int = MAX_QUOTE_CHARS) -> str:
    """``repr`` of ``text`` cut to ``limit`` characters (with the count of what was left out)."""
    r = repr(text)
    return r if len(r) <= limit else f"{r[:limit]}... ({len(r) - limit} more characters)"


def read_text(path: str | os.PathLike, what: str, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """The text of ``path``, decoded strictly as UTF-8 (a leading byte-order mark is accepted and dropped).

    what : str, what the file is for the messages (e.g. ``"layout file"``, ``"temperature CSV"``)
    max_bytes : int [bytes], larger files are refused before being read

    Raises InputError (naming the file, and for a decoding error the line and column) for a missing
    or unreadable file, a directory, a file over ``max_bytes``, UTF-16/32 text, NUL bytes or any
    byte sequence that is not UTF-8.
    """
    p = Path(path)
    try:
        with open(p, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            if size > max_bytes:
                raise InputError(f"{p}: {what} is {size} bytes, larger than the limit of {max_bytes} bytes "
                                 f"({max_bytes / 2**20:g} MiB)")
            data = fh.read(max_bytes + 1)
    except FileNotFoundError:
        raise InputError(f"{p}: {what} not found") from None
    except IsADirectoryError:
        raise InputError(f"{p}: {what} is a directory; give a file") from None
    except OSError as exc:
        raise InputError(f"{p}: cannot read {what} ({exc.strerror or exc})") from None
    if len(data) > max_bytes:  # a pipe or a file that grew while read
        raise InputError(f"{p}: {what} is larger than the limit of {max_bytes} bytes ({max_bytes / 2**20:g} MiB)")
    for bom, name in ((codecs.BOM_UTF32_LE, "UTF-32"), (codecs.BOM_UTF32_BE, "UTF-32"),
                      (codecs.BOM_UTF16_LE, "UTF-16"), (codecs.BOM_UTF16_BE, "UTF-16")):
        if data.startswith(bom):
            raise InputError(f"{p}: {what} is {name} text; valid: UTF-8 (save it as UTF-8)")
    if data.startswith(codecs.BOM_UTF8):
        data = data[len(codecs.BOM_UTF8):]
    try:
        text = data.decode("utf-8", errors="strict")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        col = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
        hint = " (UTF-16 text without a byte-order mark?)" if data[:200].count(b"\0") > 10 else ""
        raise InputError(f"{p}: {what} is not UTF-8 text: byte 0x{data[exc.start]:02x} at line {line}, column {col}"
                         f"{hint}; valid: UTF-8 (save it as UTF-8)") from None
    if "\0" in text:
        line = text.count("\n", 0, text.index("\0")) + 1
        hint = " (UTF-16 text without a byte-order mark?)" if text[:200].count("\0") > 10 else ""
        raise InputError(f"{p}: {what} contains a NUL character at line {line}{hint}; valid: UTF-8 text")
    return text
