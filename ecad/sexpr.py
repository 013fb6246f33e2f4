"""A small, bounded reader of KiCad's S-expression files (``.kicad_pcb``, KiCad 4 to 8).

``parse_sexpr(text)`` returns nested Python lists: ``(at 1.5 2 90)`` -> ``["at", 1.5, 2.0, 90.0]``.
Atoms that read as numbers become ``float``; quoted strings stay ``str`` (escapes ``\\"`` and ``\\\\``
resolved) and are wrapped in :class:`Quoted` so ``"1"`` (a pad name) is not the number 1. The parser is
iterative (no recursion limit to hit on deep nesting) and refuses, with :class:`imutherm.InputError`, an
unbalanced or truncated file, a stray token after the top expression, and nesting deeper than
:data:`MAX_DEPTH`.
"""

from __future__ import annotations

import re

from imutherm import InputError

#: deepest nesting accepted (KiCad boards nest ~8 deep; a hostile file could nest millions)
MAX_DEPTH = 200

_TOKEN = re.compile(r'\s*(?:(\()|(\))|"((?:[^"\\]|\\.)*)"|([^\s()"]+))', re.S)
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?$")


class Quoted(str):
    """A quoted atom of the file (a string even when it looks like a number)."""


def _unescape(s: str) -> str:
    return s.replace('\\"', '"').replace("\\\\", "\\") if "\\" in s else s


def parse_sexpr(text: str, where: str = "<board>") -> list:
    """The first S-expression of ``text`` as nested lists (see the module docstring)."""
    stack: list = []
    top = None
    pos, n = 0, len(text)
    while pos < n:
        m = _TOKEN.match(text, pos)
        if m is None:
            rest = text[pos:].lstrip()
            if not rest:
                break
            raise InputError(f"{where}: not a KiCad S-expression file: unreadable text at character {pos} "
                             f"({rest[:20]!r}); an unterminated string?")
        pos = m.end()
        opened, closed, quoted, atom = m.groups()
        if opened:
            if top is not None:
                raise InputError(f"{where}: not a KiCad S-expression file: text after the closing bracket of "
                                 f"the board at character {m.start()}")
            if len(stack) >= MAX_DEPTH:
                raise InputError(f"{where}: brackets nested deeper than {MAX_DEPTH} levels at character "
                                 f"{m.start()}; not a KiCad board")
            node: list = []
            if stack:
                stack[-1].append(node)
            stack.append(node)
        elif closed:
            if not stack:
                raise InputError(f"{where}: not a KiCad S-expression file: ')' without '(' at character {m.start()}")
            node = stack.pop()
            if not stack:
                top = node
        elif quoted is not None or atom is not None:
            if not stack:
                raise InputError(f"{where}: not a KiCad S-expression file: text outside brackets at character "
                                 f"{m.start()} ({m.group(0).strip()[:20]!r})")
            if quoted is not None:
                stack[-1].append(Quoted(_unescape(quoted)))
            else:
                stack[-1].append(float(atom) if _NUMBER.match(atom) else atom)
        else:  # only whitespace left
            break
    if stack:
        raise InputError(f"{where}: the file ends inside {len(stack)} unclosed bracket(s): truncated?")
    if top is None:
        raise InputError(f"{where}: no S-expression found: empty or not a KiCad board")
    return top


def head(node) -> str | None:
    """The keyword of a list node (``"at"`` of ``["at", 1, 2]``), or None for an atom or empty list."""
    return node[0] if isinstance(node, list) and node and isinstance(node[0], str) else None


def children(node, key: str) -> list:
    """The direct sub-lists of ``node`` whose keyword is ``key``."""
    return [c for c in node[1:] if isinstance(c, list) and c and c[0] == key] if isinstance(node, list) else []


def child(node, key: str):
    """The first direct sub-list of ``node`` with keyword ``key``, or None."""
    for c in node[1:] if isinstance(node, list) else ():
        if isinstance(c, list) and c and c[0] == key:
            return c
    return None


def dump_sexpr(node) -> str:
    """The text of a parsed node (:func:`parse_sexpr`'s lists back to an S-expression, one line)."""
    if isinstance(node, list):
        return "(" + " ".join(dump_sexpr(c) for c in node) + ")"
    if isinstance(node, Quoted):
        return '"' + node.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(node, float):
        return str(int(node)) if node.is_integer() else repr(node)
    return str(node)
