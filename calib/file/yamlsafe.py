"""The one guarded YAML loader: procedures, rig files, session manifests and calibration files.

Nothing in a file can construct Python objects or run code (only ``yaml.SafeLoader``'s constructors),
and hostile or broken YAML is refused while it is parsed, before any value is built, with one
:class:`HostileYaml` (the line, and the key where there is one):

- files larger than ``MAX_BYTES`` (:func:`read_text`; a caller may allow a larger kind of file) or not UTF-8;
- aliases that expand to more than ``MAX_ALIAS_VALUES`` values (``*a``: the "billion laughs" bomb is
  refused while it is expanded; an anchor shared by a few axes of a rig file is fine);
- nesting deeper than ``MAX_DEPTH`` mappings and lists (block or flow);
- tags on mappings and lists (``!!set``, ``!!python/...``; plain YAML only);
- duplicate keys (last-wins would silently pick a value) and keys that are mappings or lists;
- integers of more than ``MAX_INT_DIGITS`` digits, and scalars their tag cannot construct (``!!int ''``).

:func:`load` gives the plain value (dict, list, str, int, float, bool, None, ...); the documents
``yaml.safe_dump`` writes (every session manifest, every calibration file) are read from libyaml's events
(``yaml.cyaml.CParser``: the scanner and parser in C, one event at a time, nothing recursive), anything
else by :func:`load_located`, whose value or refusal is then the answer: the fast path only ever answers
what ``load_located`` answers (tests/rig/session/test_manifest_yaml.py). :func:`load_located` also gives a
:class:`LineMap` (the line of every key and list item) for errors that name ``file:line: key``. A syntax
error says its cause in words where it is a common one (:mod:`calib.file.yamlhints`: a tab, a dash without
a space, an unclosed quote, a colon in a value), with the line of the cause and the fix.
"""

from __future__ import annotations

import re

import yaml
from yaml.cyaml import CParser

from calib.file import yamlhints

MAX_BYTES = 1024 * 1024  # procedures, rig files, calibration files (a session manifest may be larger)
MAX_DEPTH = 32  # nesting levels of mappings and lists
MAX_ALIAS_VALUES = 10_000  # values built through aliases (a document may repeat an anchor, not explode)
MAX_INT_DIGITS = 30  # no field needs more (serial numbers are 32-bit)
_PLAIN_COLLECTIONS = ("tag:yaml.org,2002:map", "tag:yaml.org,2002:seq", "tag:yaml.org,2002:omap")


class HostileYaml(ValueError):
    """Bad or hostile YAML: ``message`` what is wrong, ``line`` 1-based or None, ``key`` or None.

    ``str()`` is ``key: message`` (the caller adds the file and the line)."""

    def __init__(self, message: str, line: int | None = None, key: str | None = None) -> None:
        self.message, self.line, self.key = message, line, key
        super().__init__(f"{key}: {message}" if key else message)


class LineMap:
    """Line numbers (1-based) of the keys of mappings and the items of lists of a loaded document."""

    def __init__(self) -> None:
        self._lines: dict[int, dict] = {}
        self._own: dict[int, int] = {}
        self._keep: list = []  # keep containers alive so their ids stay unique

    def line_of(self, container, key=None) -> int | None:
        """The line of ``container[key]`` (its key's line in a mapping); of the container itself without a key."""
        if key is None:
            return self._own.get(id(container))
        return self._lines.get(id(container), {}).get(key, self._own.get(id(container)))

    def _record(self, container, node, lines: dict) -> None:
        self._lines[id(container)] = lines
        self._own[id(container)] = node.start_mark.line + 1
        self._keep.append(container)


# -- reading a file ------------------------------------------------------------------------------------
def _size(n: int) -> str:
    return f"{n // (1024 * 1024)} MiB" if n % (1024 * 1024) == 0 else f"{n // 1024} kB"


def read_text(path, what: str = "file of this kind", max_bytes: int = MAX_BYTES) -> str:
    """The text of the file at ``path`` (newlines as ``open()`` gives them); HostileYaml when it is larger
    than ``max_bytes`` (read no further: a device or a pipe never ends) or not UTF-8. OSError passes through."""
    with open(path, "rb") as fh:
        data = fh.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise HostileYaml(f"larger than {_size(max_bytes)}: not a {what}")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise HostileYaml(f"not a text file (byte {exc.start} is not UTF-8)") from None
    return text.replace("\r\n", "\n").replace("\r", "\n")


# -- the located loader ---------------------------------------------------------------------------------
def load_located(text: str):
    """Parse YAML text; return (value, :class:`LineMap`). Bad or hostile YAML: one :class:`HostileYaml`."""
    loader = None
    try:
        loader = _GuardedLoader(text)
        node = loader.get_single_node()
        if node is None:
            return None, LineMap()
        builder = _Builder(loader)
        return builder.build(node), builder.lines
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        line = mark.line + 1 if mark is not None else None
        if isinstance(exc, yaml.reader.ReaderError):  # a control character: its position, no mark
            line = text.count("\n", 0, exc.position) + 1
        problem = getattr(exc, "problem", None) or (str(exc).splitlines() or ["unreadable"])[0]
        if isinstance(exc, (yaml.scanner.ScannerError, yaml.parser.ParserError)):  # syntax: the cause in words
            context = getattr(exc, "context_mark", None)
            line, problem = yamlhints.explain(text, problem, line, context.line + 1 if context else None)
        raise HostileYaml(f"not valid YAML: {problem}", line) from None
    except RecursionError:  # a backstop: MAX_DEPTH keeps the composer far from the interpreter's limit
        raise HostileYaml("not valid here: nested too deeply") from None
    finally:
        if loader is not None:
            loader.dispose()


def _nested_too_deep(line: int) -> HostileYaml:
    return HostileYaml(f"not valid here: nested more than {MAX_DEPTH} levels deep", line)


class _GuardedLoader(yaml.SafeLoader):
    """SafeLoader whose scanner and composer refuse documents nested deeper than ``MAX_DEPTH`` and note
    which nodes aliases point at (the builder bounds what they expand to)."""

    def __init__(self, text: str) -> None:
        super().__init__(text)
        self.depth = 0
        self.aliased: set[int] = set()  # ids of the nodes an alias refers to

    def fetch_flow_collection_start(self, TokenClass):
        # the scanner looks ahead through a whole flow collection: stop "[[[[..." before it does
        if self.flow_level >= MAX_DEPTH:
            raise _nested_too_deep(self.line + 1)
        super().fetch_flow_collection_start(TokenClass)

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):  # the anchored node, shared: the builder counts its copies
            node = super().compose_node(parent, index)
            self.aliased.add(id(node))
            return node
        self.depth += 1
        try:
            if self.depth > MAX_DEPTH:
                raise _nested_too_deep(self.peek_event().start_mark.line + 1)
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1


class _Builder:
    """Node graph -> plain values, recording the line of every key and item."""

    def __init__(self, loader: yaml.SafeLoader) -> None:
        self.loader, self.lines = loader, LineMap()
        self.aliased: set[int] = getattr(loader, "aliased", set())
        self.seen: set[int] = set()  # aliased nodes built once already (a second build is an alias's copy)
        self.copying = 0  # > 0 while an alias's copy is built
        self.copied = 0  # values built through aliases

    def build(self, n):
        """The value of node ``n``; an alias's copy counts towards ``MAX_ALIAS_VALUES``."""
        if id(n) not in self.aliased:
            return self._build(n) if not self.copying else self._count(n)
        copy = id(n) in self.seen
        self.seen.add(id(n))
        self.copying += copy
        try:
            return self._count(n) if self.copying else self._build(n)
        finally:
            self.copying -= copy

    def _count(self, n):
        self.copied += 1
        if self.copied > MAX_ALIAS_VALUES:
            self.fail(n, f"not valid here: aliases expand to more than {MAX_ALIAS_VALUES} values")
        return self._build(n)

    @staticmethod
    def fail(node, message, key=None):
        raise HostileYaml(message, node.start_mark.line + 1, key)

    def _build(self, n):
        if isinstance(n, (yaml.MappingNode, yaml.SequenceNode)) and n.tag not in _PLAIN_COLLECTIONS:
            self.fail(n, f"not valid YAML here: tag {n.tag!r} is not allowed (plain YAML only)")
        if isinstance(n, yaml.MappingNode):
            return self.mapping(n)
        if isinstance(n, yaml.SequenceNode):
            lst = [self.build(v) for v in n.value]
            self.lines._record(lst, n, {i: v.start_mark.line + 1 for i, v in enumerate(n.value)})
            return lst
        return self.scalar(n)

    def mapping(self, n) -> dict:
        out: dict = {}
        lines: dict = {}
        for k_node, v_node in n.value:
            if not isinstance(k_node, yaml.ScalarNode):
                self.fail(k_node, "a key must be a plain value, not a mapping or a list")
            k = self.scalar(k_node)
            if k in out:
                self.fail(k_node, "duplicate key" + yamlhints.dash_key(k), str(k))
            out[k] = self.build(v_node)
            lines[k] = k_node.start_mark.line + 1
        self.lines._record(out, n, lines)
        return out

    def scalar(self, n):
        if n.tag == _INT and len(n.value.replace("_", "").lstrip("+-")) > MAX_INT_DIGITS:
            self.fail(n, f"not valid here: a number of more than {MAX_INT_DIGITS} digits")
        try:
            return self.loader.construct_object(n, deep=True)
        except yaml.YAMLError as exc:
            problem = getattr(exc, "problem", None) or (str(exc).splitlines() or [""])[0]
            self.fail(n, f"not valid YAML: {problem}")
        except ValueError as exc:  # e.g. a malformed timestamp or base64 value
            self.fail(n, f"not valid YAML: {(str(exc).splitlines() or ['bad value'])[0]}")
        except (ArithmeticError, AttributeError, IndexError, KeyError, TypeError):
            # SafeConstructor on a value its tag cannot hold: !!int '' (IndexError), !!bool x (KeyError),
            # !!timestamp x (AttributeError)
            tag = n.tag.replace("tag:yaml.org,2002:", "!!")
            value = repr(n.value) if len(n.value) <= 40 else repr(n.value[:37]) + "..."
            self.fail(n, f"not valid YAML: {value} is not a valid {tag} value")


# -- the fast path ---------------------------------------------------------------------------------------
def load(text: str):
    """The plain value of YAML ``text`` (dict, list, str, int, float, bool, None, ...), as :func:`load_located`
    gives it, and its refusals, faster for the plain documents ``yaml.safe_dump`` writes."""
    try:
        return _load_plain(text)
    except Exception:  # noqa: BLE001 - _NotPlain, or anything libyaml or a constructor says: load_located decides
        return load_located(text)[0]


_INT, _FLOAT, _STR = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float", "tag:yaml.org,2002:str"
_RESOLVERS = yaml.SafeLoader.yaml_implicit_resolvers
_SIMPLE_INT = re.compile(r"[-+]?(?:0|[1-9][0-9]*)\Z")
_SIMPLE_FLOAT = re.compile(r"[-+]?[0-9][0-9.eE+-]*\Z")
#: where a plain scalar in a flow collection ends at one of these, libyaml and PyYAML differ
_FLOW_INDICATORS = re.compile(r"[?:#,\[\]{}]")
#: the fast path reads newlines and printable characters only (no tabs, carriage returns, control characters,
#: byte-order marks or the Unicode line and paragraph separators: libyaml and PyYAML differ on some of them)
_NOT_PLAIN_TEXT = re.compile("[^\n\x20-\x7e\xa0-\u2027\u202a-\ud7ff\ue000-\ufefe\uff00-\ufffd]")
_NO_KEY = object()


class _NotPlain(Exception):
    """The document is not one the fast path reads: :func:`load_located` decides."""


def _load_plain(text: str):
    """``text``'s value by the fast path (:class:`_NotPlain` or libyaml's error when it does not read it):
    printable text, mappings, lists and scalars, no anchors, aliases or tags, no duplicate keys, at most
    ``MAX_DEPTH`` deep, integers of at most ``MAX_INT_DIGITS`` digits."""
    if _NOT_PLAIN_TEXT.search(text):
        raise _NotPlain
    parser = CParser(text)
    constructor = yaml.SafeLoader("")  # scalar constructors of the tags other than int, float and str
    try:
        return _build_events(parser, constructor)
    finally:
        parser.dispose()


def _build_events(parser, constructor):
    """The single document's value from the parser's events (:class:`_NotPlain` for anything else)."""
    stack: list = []  # [container, pending key or _NO_KEY, flow style]
    root = _NO_KEY
    seen: dict = {}  # (text, plain) -> value: keys and repeated values resolved once (all immutable)
    flows = 0  # flow collections open
    while True:
        event = parser.get_event()
        kind = type(event)
        if kind is yaml.ScalarEvent:
            if event.anchor is not None or event.tag is not None or len(stack) >= MAX_DEPTH or (
                    flows and event.implicit[0] and _FLOW_INDICATORS.search(event.value)):
                raise _NotPlain
            memo = (event.value, event.implicit[0])
            value = seen[memo] if memo in seen else seen.setdefault(memo, _scalar(event, constructor))
        elif kind is yaml.MappingStartEvent or kind is yaml.SequenceStartEvent:
            if event.anchor is not None or event.tag is not None or len(stack) >= MAX_DEPTH:
                raise _NotPlain
            stack.append([{} if kind is yaml.MappingStartEvent else [], _NO_KEY, bool(event.flow_style)])
            flows += stack[-1][2]
            continue
        elif kind is yaml.MappingEndEvent or kind is yaml.SequenceEndEvent:
            value, _, flow = stack.pop()
            flows -= flow
        elif kind is yaml.StreamEndEvent:
            return None if root is _NO_KEY else root
        elif kind is yaml.StreamStartEvent or kind is yaml.DocumentEndEvent:
            continue
        elif kind is yaml.DocumentStartEvent:
            if root is not _NO_KEY or event.explicit or event.version or event.tags:
                raise _NotPlain  # a second document, directives: load_located decides
            continue
        else:  # an alias
            raise _NotPlain
        if not stack:
            root = value
        else:
            _add(stack[-1], value)


def _add(top: list, value) -> None:
    """Put ``value`` into the open container ``top`` ([container, pending key, flow style])."""
    container = top[0]
    if isinstance(container, list):
        container.append(value)
    elif top[1] is _NO_KEY:
        if isinstance(value, (dict, list)) or value in container:
            raise _NotPlain  # a key that is a collection, a duplicate key
        top[1] = value
    else:
        container[top[1]] = value
        top[1] = _NO_KEY


def _scalar(event, constructor):
    """A scalar's value as SafeLoader resolves and constructs it (int, float and str directly)."""
    value = event.value
    tag = _STR
    if event.implicit[0]:
        for tag_, regexp in _RESOLVERS.get(value[:1], []) + _RESOLVERS.get(None, []):
            if regexp.match(value):
                tag = tag_
                break
    if tag is _STR or tag == _STR:
        return value
    if tag == _INT:
        if len(value.replace("_", "").lstrip("+-")) > MAX_INT_DIGITS:
            raise _NotPlain
        if _SIMPLE_INT.match(value):
            return int(value)
    elif tag == _FLOAT and _SIMPLE_FLOAT.match(value):
        return float(value)
    return constructor.construct_object(yaml.ScalarNode(tag, value, event.start_mark, event.end_mark), deep=True)
