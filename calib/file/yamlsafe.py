"""Reading YAML that may be hostile: the calibration file loader's guards.

A calibration file is data written by ``calib.file.calibration.write`` (no aliases, no duplicate keys, a
few kB). Anything else is refused before it is built: aliases (the "billion laughs" bomb),
duplicate keys (last-wins would silently pick a value), nesting deeper than ``MAX_DEPTH``, files
over ``MAX_BYTES``, integers longer than ``MAX_INT_DIGITS`` digits, text that is not UTF-8.
"""

from __future__ import annotations

from pathlib import Path

import yaml

MAX_BYTES = 1024 * 1024
MAX_DEPTH = 32
MAX_INT_DIGITS = 30


class HostileYaml(ValueError):
    """The text is not a plain YAML document of the expected kind; ``line`` is 1-based or None."""

    def __init__(self, message: str, line: int | None = None) -> None:
        super().__init__(message)
        self.line = line


class _GuardedLoader(yaml.SafeLoader):
    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            raise HostileYaml("aliases are not allowed in this file", self.peek_event().start_mark.line + 1)
        self._depth = getattr(self, "_depth", 0) + 1
        try:
            if self._depth > MAX_DEPTH:
                raise HostileYaml(f"nested more than {MAX_DEPTH} levels deep", self.peek_event().start_mark.line + 1)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                raise HostileYaml("a mapping or list used as a key", key_node.start_mark.line + 1)
            if key_node.value in seen:
                raise HostileYaml(f"duplicate key {key_node.value!r}", key_node.start_mark.line + 1)
            seen.add(key_node.value)
        return super().construct_mapping(node, deep=deep)

    def construct_yaml_int(self, node):
        if len(node.value.replace("_", "").lstrip("+-")) > MAX_INT_DIGITS:
            raise HostileYaml(f"a number of more than {MAX_INT_DIGITS} digits", node.start_mark.line + 1)
        return super().construct_yaml_int(node)


_GuardedLoader.add_constructor("tag:yaml.org,2002:int", _GuardedLoader.construct_yaml_int)


def read_text(path) -> str:
    """The file's text; HostileYaml when it is too large or not UTF-8 (OSError passes through)."""
    p = Path(path)
    if p.stat().st_size > MAX_BYTES:
        raise HostileYaml(f"larger than {MAX_BYTES // 1024} kB: not a file of this kind")
    try:
        return p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise HostileYaml(f"not a text file (byte {exc.start} is not UTF-8)") from None


def load(text: str):
    """Parse one YAML document with the guards; yaml.YAMLError for plain syntax errors."""
    try:
        return yaml.load(text, Loader=_GuardedLoader)  # noqa: S506 - a SafeLoader subclass
    except RecursionError:
        raise HostileYaml("nested too deeply") from None
