"""Safe, bounded YAML loading that remembers where every value came from.

``load_located(text, path)`` returns plain Python values (dict, list, str,
int, float, bool, None) plus a ``Located`` map from id() of every mapping and
list to the line of each of its keys/items, so validators can say
``procedures/x.yaml:14: steps[3].pose: ...``. Only ``yaml.SafeLoader`` is
used: nothing in a file can construct Python objects or run code.

Hostile input is refused at parse time with one located line: tags on
collections, duplicate keys, keys that are mappings or lists, nesting deeper
than ``MAX_DEPTH``, aliases that expand to more than ``MAX_ALIAS_VALUES``
values ("billion laughs"), integers longer than ``MAX_INT_DIGITS`` digits, and
(in :func:`read_source`) files that are too large or not UTF-8 text.
"""

from __future__ import annotations

import errno
from pathlib import Path

import yaml

from rig.errors import RigInputError

MAX_DEPTH = 64  # nesting levels of mappings and lists
MAX_ALIAS_VALUES = 10_000  # values reached again through aliases
MAX_INT_DIGITS = 30  # no field needs more (serial numbers are 32-bit)
MAX_BYTES = 4 * 1024 * 1024
_PLAIN_COLLECTIONS = ("tag:yaml.org,2002:map", "tag:yaml.org,2002:seq", "tag:yaml.org,2002:omap")


class Located:
    """Line numbers (1-based) of the keys of mappings and the items of lists."""

    def __init__(self) -> None:
        self._lines: dict[int, dict] = {}
        self._own: dict[int, int] = {}
        self._keep: list = []  # keep containers alive so their ids stay unique

    def line_of(self, container, key=None) -> int | None:
        if key is None:
            return self._own.get(id(container))
        return self._lines.get(id(container), {}).get(key, self._own.get(id(container)))

    def _record(self, container, node, lines: dict) -> None:
        self._lines[id(container)] = lines
        self._own[id(container)] = node.start_mark.line + 1
        self._keep.append(container)


class _BoundedLoader(yaml.SafeLoader):
    """SafeLoader whose scanner and composer refuse documents nested deeper than ``MAX_DEPTH``."""

    def __init__(self, text: str, path: str) -> None:
        super().__init__(text)
        self.source_path = path
        self.depth = 0

    def fetch_flow_collection_start(self, TokenClass):
        # the scanner looks ahead through a whole flow collection: stop "[[[[..." before it does
        if self.flow_level >= MAX_DEPTH:
            raise RigInputError(self.source_path, self.line + 1, None,
                                f"not valid here: nested more than {MAX_DEPTH} levels deep")
        super().fetch_flow_collection_start(TokenClass)

    def compose_node(self, parent, index):
        self.depth += 1
        try:
            if self.depth > MAX_DEPTH:
                mark = self.peek_event().start_mark
                raise RigInputError(self.source_path, mark.line + 1, None,
                                    f"not valid here: nested more than {MAX_DEPTH} levels deep")
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1


class _ErrnoMatch(type):
    """``isinstance(exc, cls)`` is true for any OSError whose errno is in ``cls.errnos``."""

    def __instancecheck__(cls, exc) -> bool:
        return isinstance(exc, OSError) and exc.errno in cls.errnos


class SymlinkLoop(OSError, metaclass=_ErrnoMatch):
    """Matches (``isinstance``, not ``except``) any OSError with errno ELOOP: a path that is a loop of
    symbolic links. Whoever opened the file, this is bad input (the CLI's exit-code table says 2)."""

    errnos = (errno.ELOOP,)
    message = "a symbolic link loop (too many levels of symbolic links)"


def read_source(path, what: str, missing: str) -> str:
    """The text of ``path``; a one-line RigInputError if it is missing, a directory, too large or not text."""
    p = Path(path)
    try:
        if p.stat().st_size > MAX_BYTES:
            raise RigInputError(str(p), None, None, f"larger than {MAX_BYTES // (1024 * 1024)} MiB: not a {what}")
        return p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise RigInputError(str(p), None, None, missing) from None
    except IsADirectoryError:
        raise RigInputError(str(p), None, None, f"is a directory, expected a {what} YAML file") from None
    except UnicodeDecodeError as exc:
        raise RigInputError(str(p), None, None, f"not a text file (byte {exc.start} is not UTF-8)") from None
    except OSError as exc:  # (``except SymlinkLoop`` would not match: except clauses ignore __instancecheck__)
        if isinstance(exc, SymlinkLoop):
            raise RigInputError(str(p), None, None, f"{SymlinkLoop.message}, expected a {what} YAML file") from None
        raise RigInputError(str(p), None, None, f"cannot read: {exc.strerror or exc}") from None


def _yaml_error(exc: yaml.YAMLError, path: str) -> RigInputError:
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    problem = getattr(exc, "problem", None) or (str(exc).splitlines() or ["unreadable"])[0]
    return RigInputError(path, mark.line + 1 if mark is not None else None, None, f"not valid YAML: {problem}")


def load_located(text: str, path: str):
    """Parse YAML text; return (value, Located). Raises a one-line RigInputError on bad or hostile YAML."""
    loader = None
    try:
        loader = _BoundedLoader(text, path)
        node = loader.get_single_node()
        if node is None:
            return None, Located()
        builder = _Builder(loader, path)
        return builder.build(node), builder.loc
    except yaml.YAMLError as exc:
        raise _yaml_error(exc, path) from None
    except RecursionError:  # a backstop: MAX_DEPTH keeps the composer far from the interpreter's limit
        raise RigInputError(path, None, None, "not valid here: nested too deeply") from None
    finally:
        if loader is not None:
            loader.dispose()


class _Builder:
    """Node graph -> plain values, recording lines; counts values reached again through aliases."""

    def __init__(self, loader: yaml.SafeLoader, path: str) -> None:
        self.loader, self.path, self.loc = loader, path, Located()
        self.seen: set[int] = set()
        self.alias_values = 0

    def fail(self, node, message, key=None):
        raise RigInputError(self.path, node.start_mark.line + 1, key, message)

    def build(self, n):
        if id(n) in self.seen:
            self.alias_values += 1
            if self.alias_values > MAX_ALIAS_VALUES:
                self.fail(n, f"not valid here: aliases expand to more than {MAX_ALIAS_VALUES} values "
                             "(an alias bomb?)")
        self.seen.add(id(n))
        if isinstance(n, (yaml.MappingNode, yaml.SequenceNode)) and n.tag not in _PLAIN_COLLECTIONS:
            self.fail(n, f"not valid YAML here: tag {n.tag!r} is not allowed (plain YAML only)")
        if isinstance(n, yaml.MappingNode):
            return self.mapping(n)
        if isinstance(n, yaml.SequenceNode):
            lst = [self.build(v) for v in n.value]
            self.loc._record(lst, n, {i: v.start_mark.line + 1 for i, v in enumerate(n.value)})
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
                self.fail(k_node, "duplicate key", str(k))
            out[k] = self.build(v_node)
            lines[k] = k_node.start_mark.line + 1
        self.loc._record(out, n, lines)
        return out

    def scalar(self, n):
        if n.tag == "tag:yaml.org,2002:int" and len(n.value.replace("_", "").lstrip("+-")) > MAX_INT_DIGITS:
            self.fail(n, f"not valid here: a number of more than {MAX_INT_DIGITS} digits")
        try:
            return self.loader.construct_object(n, deep=True)
        except yaml.YAMLError as exc:
            problem = getattr(exc, "problem", None) or (str(exc).splitlines() or [""])[0]
            self.fail(n, f"not valid YAML: {problem}")
        except ValueError as exc:  # e.g. a malformed timestamp or base64 value
            self.fail(n, f"not valid YAML: {(str(exc).splitlines() or ['bad value'])[0]}")
