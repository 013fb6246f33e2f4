"""Render the package's plain-text docstrings as valid reStructuredText, without editing the code.

Many docstrings of imutherm list their fields or parameters as aligned text (``name : type [unit], what``
with indented continuation lines) outside a numpydoc ``Parameters`` section, and write absolute values as
``|x|``. Read as reStructuredText, the first are stray indentation and the second substitution references.
This hook, run on every docstring before numpydoc parses it, changes only how such text is *marked up*:

- outside the numpydoc sections whose bodies are parameter lists, each item line (``name : ...`` or
  ````name``  text``) with its continuation lines becomes one bullet item, and other indented continuation
  lines are joined to the line they continue (literal blocks after ``::`` and directives are kept; a literal
  block that the docstring's dedent left unindented is indented again);
- a heading that is not a numpydoc section (and any heading of a module docstring) becomes a rubric,
  since numpydoc drops the text of sections it does not know;
- every ``|`` outside inline literals, roles and literal blocks is escaped;
- an ``Examples`` section (doctest lines, ``>>>``) is left exactly as written.

The words are unchanged, so the API reference says what the docstrings say.
"""

from __future__ import annotations

import re

#: numpydoc sections whose bodies are ``name : type`` lists that numpydoc itself parses
NUMPYDOC_SECTIONS = {"parameters", "returns", "yields", "receives", "other parameters", "raises", "warns",
                     "warnings", "see also", "notes", "references", "examples", "attributes", "methods"}
LIST_SECTIONS = {"parameters", "returns", "yields", "receives", "other parameters", "raises", "warns",
                 "attributes", "methods"}
#: sections kept verbatim: doctest blocks (a ``|`` there is code, and a continuation line is its own line)
VERBATIM_SECTIONS = {"examples"}
ITEM = re.compile(r"^(?P<name>\*{0,2}[A-Za-z_][\w.\[\]'*]*(?:, ?\*{0,2}[A-Za-z_][\w.\[\]'*]*)*) : (?P<rest>.*)$")
LITERAL_ITEM = re.compile(r"^(?P<name>``[^`]+``)(?: +|: )(?P<rest>[^\s:,.;)].*)$")
BULLET = re.compile(r"^([-*+•]|\d+[.)]|\(\d+\)|[a-z][.)]) ")
SPAN = re.compile(r"(:[\w:+-]+:)?`[^`]*`+_*|``[^`]+``")


def indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def escape_bars(line: str) -> str:
    """Escape ``|`` outside inline literals and roles (a substitution reference otherwise)."""
    out, pos = [], 0
    for m in SPAN.finditer(line):
        out.append(line[pos:m.start()].replace("|", r"\|"))
        out.append(m.group(0))
        pos = m.end()
    out.append(line[pos:].replace("|", r"\|"))
    return "".join(out)


def is_header(lines: list[str], i: int) -> bool:
    return (i + 1 < len(lines) and lines[i].strip() != "" and re.fullmatch(r"\s*-{3,}\s*", lines[i + 1]) is not None
            and indent(lines[i]) == 0)


def prose(block: list[str]) -> list[str]:
    """One stretch of free text: items to bullets, continuation lines joined, literal blocks kept."""
    out: list[str] = []
    i, n = 0, len(block)
    in_list = False
    while i < n:
        line = block[i]
        if not line.strip():
            out.append(line)
            in_list = False
            i += 1
            continue
        base = indent(line)
        stripped = line.strip()
        if stripped.startswith(".. ") or (stripped.endswith("::") and not stripped.startswith(":")):
            if stripped.endswith("::") and stripped != "::" and not any(x.strip() for x in out):
                # the summary line opens the literal block; numpydoc dedents the text after the summary, so
                # the block is opened by a bare "::" paragraph of its own ("text::" renders as "text:")
                out.extend([line[:-1], "", " " * base + "::"])
            else:
                out.append(line)   # a directive or a literal block: its indented body verbatim
            i += 1
            j = i
            while j < n and not block[j].strip():
                j += 1
            if stripped.endswith("::") and j < n and indent(block[j]) <= base:
                # the docstring's dedent took the literal block's indentation away (its first line was the
                # summary): indent the block's lines again, up to the next blank line
                out.extend(block[i:j])
                while j < n and block[j].strip():
                    out.append(" " * (base + 4) + block[j].strip())
                    j += 1
                i = j
            while i < n and (not block[i].strip() or indent(block[i]) > base):
                out.append(block[i])
                i += 1
            in_list = False
            continue
        text = stripped
        i += 1
        while i < n and block[i].strip() and indent(block[i]) > base and not block[i].strip().startswith(".. "):
            text += " " + block[i].strip()           # continuation lines joined to the line they continue
            i += 1
        m = ITEM.match(text) or LITERAL_ITEM.match(text)
        bullet = BULLET.match(text)
        if m or bullet:
            if out and out[-1].strip() and not in_list:
                out.append("")
            if m:
                name = m.group("name")
                name = name if name.startswith("``") else f"``{name}``"
                text = f"- {name} : {m.group('rest')}"
            out.append(" " * base + text)
            in_list = True
        else:
            if in_list:
                out.append("")
            out.append(" " * base + text)
            in_list = False
    return out


def rewrite(lines: list[str], module: bool = False) -> list[str]:
    """The docstring's lines with the plain-text layout turned into reStructuredText (see the module)."""
    out: list[str] = []
    verbatim: set[int] = set()   # indices into out of the lines of VERBATIM_SECTIONS
    section = None
    block: list[str] = []

    def flush():
        if section in VERBATIM_SECTIONS:
            verbatim.update(range(len(out), len(out) + len(block)))
        out.extend(block if section in LIST_SECTIONS or section in VERBATIM_SECTIONS else prose(block))
        block.clear()

    i = 0
    while i < len(lines):
        if is_header(lines, i):
            flush()
            section = lines[i].strip().lower()
            if module or section not in NUMPYDOC_SECTIONS:
                out.extend([f".. rubric:: {lines[i].strip()}", ""])   # numpydoc would drop an unknown section
                section = None
            else:
                out.extend([lines[i], lines[i + 1]])
            i += 2
            continue
        block.append(lines[i])
        i += 1
    flush()
    # bars escaped outside literal blocks
    result, literal_at = [], None
    for i, line in enumerate(out):
        if i in verbatim:
            result.append(line)
            continue
        if literal_at is not None and (not line.strip() or indent(line) > literal_at):
            result.append(line)
            continue
        literal_at = None
        result.append(escape_bars(line))
        s = line.strip()
        if s.endswith("::") and not s.startswith(".. "):
            literal_at = indent(line)
    return result


def process(app, what, name, obj, options, lines):
    origin = getattr(obj, "__module__", None) if what != "module" else getattr(obj, "__name__", "")
    if what != "module" and isinstance(origin, str) and not origin.startswith("imutherm"):
        lines[:] = []   # an imported name (e.g. scipy's lfilter): autodoc leaves it out; nothing to parse
        return
    lines[:] = rewrite(list(lines), module=what == "module")


def setup(app):
    app.connect("autodoc-process-docstring", process, priority=100)   # before numpydoc (priority 500)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
