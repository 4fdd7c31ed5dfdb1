"""YAML syntax errors in words: the common causes of a parse error, found in the text, with a fix.

The parser says where it gave up (``expected <block end>, but found '?'``), which is often a line after the
cause and always in its own words. :func:`explain` looks at the text up to that line for the mistakes people
make when they write YAML by hand, nearest first, and says what it found, on which line, and what to write
instead:

=====================================  ============================================================
cause                                  example (the fix)
=====================================  ============================================================
a tab in the indentation               ``\\t- pose: "+X up"`` (spaces only)
no space after a list item's dash      ``-pose: "+X up"`` (``- pose: "+X up"``)
a quote that is not closed             ``- pose: "+X up`` (``- pose: "+X up"``)
a colon and a space inside a value     ``name: roll 30: pitch -30`` (``name: "roll 30: pitch -30"``)
=====================================  ============================================================

Anything else keeps the parser's own words, with the few phrases that are pure jargon said plainly
(:data:`PLAIN_WORDS`). Pure: text in, (line, message) out; :mod:`calib.file.yamlsafe` calls it when the
parser refuses a document.
"""

from __future__ import annotations

import re
from typing import Callable, NamedTuple


class Hint(NamedTuple):
    """A cause found in the text: ``line`` 1-based, ``message`` what is wrong and what to write instead."""

    line: int
    message: str


_LEADING_TAB = re.compile(r"[ ]*\t")
_DASH_NO_SPACE = re.compile(r"(?P<indent>\s*)-(?P<rest>[A-Za-z_\"'{\[].*)")
_KEY_VALUE = re.compile(r"(?P<head>\s*(?:-\s+)?)(?P<key>[A-Za-z_][\w.-]*):[ ]+(?P<value>.+)")


def _tab(line: str) -> str | None:
    if _LEADING_TAB.match(line):
        return "a tab in the indentation: YAML indents with spaces only; replace the tab with spaces"
    return None


def _dash(line: str) -> str | None:
    m = _DASH_NO_SPACE.fullmatch(line.rstrip())
    if m is None:
        return None
    fixed = f"{m['indent']}- {m['rest']}".strip()
    return f"a list item needs a space after its dash: write '{fixed}' instead of '{line.strip()}'"


def dash_key(key) -> str:
    """For a key that is a list item without the space after its dash (``-pose``, which YAML reads as a key
    of a mapping): what to write instead; empty for any other key."""
    if isinstance(key, str) and _DASH_NO_SPACE.fullmatch(key) and key[1:2].isalpha():
        return f"; a list item needs a space after its dash: write '- {key[1:]}: ...' instead of '{key}: ...'"
    return ""


def _unclosed_quote(line: str) -> str | None:
    """The quote a line opens and does not close. A quote opens a value only where a value starts (after
    the indentation, ``- ``, ``: ``, and ``[``, ``{`` or ``,`` in a flow collection); elsewhere it is a
    character of the text (``rock 'n' roll``)."""
    quote, start, flow, i = None, True, 0, 0
    while i < len(line):
        c = line[i]
        if quote is not None:
            if c == "\\" and quote == '"':
                i += 1  # an escaped character inside double quotes
            elif c == quote and quote == "'" and line[i + 1:i + 2] == "'":
                i += 1  # '' is a quote inside single quotes
            elif c == quote:
                quote, start = None, False
        elif c in "\"'" and start:
            quote = c
        elif c == "#" and (i == 0 or line[i - 1] in " \t"):
            break  # a comment
        elif c in "[{":
            flow, start = flow + 1, True
        elif c in "]}":
            flow, start = max(flow - 1, 0), False
        elif c not in " \t":
            nxt = line[i + 1:i + 2]
            start = (c == "," and flow > 0) or (c in "-:" and nxt in (" ", ""))
        i += 1
    if quote is None:
        return None
    return f"the quote {quote} opened on this line is not closed: end the value with it: {line.strip()}{quote}"


def _colon_in_value(line: str) -> str | None:
    m = _KEY_VALUE.fullmatch(line.split(" #", 1)[0].rstrip())
    if m is None:
        return None
    value = m["value"]
    if value[0] in "\"'{[|>&*!" or not (": " in value or value.endswith(":")):
        return None
    quoted = f"'{value}'" if '"' in value else f'"{value}"'
    return (f"the value of '{m['key']}' contains ': ', which YAML reads as another key: put the value in "
            f"quotes: {m['key']}: {quoted}")


#: the causes, each a check of one line (None: not this cause), tried on the lines up to the parser's
HINTS: tuple[Callable[[str], str | None], ...] = (_tab, _dash, _unclosed_quote, _colon_in_value)

#: the parser's jargon -> what it means, and whether the line to name is where the parser's context began
#: (the start of the key it was reading) rather than where it gave up; for a cause none of HINTS finds
PLAIN_WORDS: dict[str, tuple[str, bool]] = {
    "expected <block end>, but found": ("this line does not line up with the lines above it (indentation, "
                                        "or a list item where a key is expected)", False),
    "mapping values are not allowed here": ("a ':' where no key can start; put a value that contains ': ' in "
                                            "quotes", False),
    "could not find expected ':'": ("a line that is neither 'key: value' nor a list item '- ...' (a missing ':' "
                                    "after a key?)", True),
    "found character '\\t' that cannot start any token": ("a tab where YAML expects spaces", False),
    "expected ',' or '}'": ("a {...} is not closed, or two of its entries lack the comma between them (or a "
                            "quote inside it is not closed)", False),
    "expected ',' or ']'": ("a [...] is not closed, or two of its items lack the comma between them (or a "
                            "quote inside it is not closed)", False),
}


_BLOCK_SCALAR = re.compile(r".*(?:^|[ ])[|>][-+0-9]*\s*(?:#.*)?")


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip(" "))


def _block_scalar_lines(lines: list[str]) -> set[int]:
    """The (1-based) lines of the text of block scalars (``description: |`` and the lines indented below it)."""
    inside, owner = set(), None
    for number, text in enumerate(lines, 1):
        if owner is not None and (not text.strip() or _indent(text) > owner):
            inside.add(number)
            continue
        owner = _indent(text) if _BLOCK_SCALAR.fullmatch(text.rstrip()) else None
    return inside


def explain(text: str, problem: str, line: int | None, context_line: int | None = None) -> tuple[int | None, str]:
    """The line and the words of a parse error: a cause of :data:`HINTS` found on the parser's ``line`` or
    the nearest line above it (a quote opened earlier, a dash two lines up), else ``problem`` with its
    jargon said plainly (:data:`PLAIN_WORDS`). ``line`` is 1-based (None: the whole text is searched from the
    end); ``context_line`` the line where the parser's context began (the key it was reading), if any."""
    lines = text.split("\n")
    last = min(line or len(lines), len(lines))
    literal = _block_scalar_lines(lines)
    for number in range(last, 0, -1):
        if number in literal:
            continue  # the text of a `|` or `>` block: anything goes there
        for hint in HINTS:
            message = hint(lines[number - 1])
            if message:
                return number, message
    for jargon, (words, at_context) in PLAIN_WORDS.items():
        if problem.startswith(jargon):
            return (context_line or line) if at_context else line, words
    return line, problem
