"""Safe YAML loading that remembers where every value came from.

``load_located(text, path)`` returns plain Python values (dict, list, str,
int, float, bool, None) plus a ``Lines`` map from id() of every mapping and
list to the line of each of its keys/items, so validators can say
``procedures/x.yaml:14: steps[3].pose: ...``. Only ``yaml.SafeLoader`` is
used: nothing in a file can construct Python objects or run code.
"""

from __future__ import annotations

import yaml

from rig.errors import RigInputError


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


def load_located(text: str, path: str):
    """Parse YAML text; return (value, Located). Raises RigInputError on YAML errors."""
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise RigInputError(path, line, None, f"not valid YAML: {problem}") from None
    loc = Located()
    if node is None:
        return None, loc
    loader = yaml.SafeLoader("")

    def build(n):
        if isinstance(n, (yaml.MappingNode, yaml.SequenceNode)) and n.tag not in (
                "tag:yaml.org,2002:map", "tag:yaml.org,2002:seq", "tag:yaml.org,2002:omap"):
            raise RigInputError(path, n.start_mark.line + 1, None,
                                f"not valid YAML here: tag {n.tag!r} is not allowed (plain YAML only)")
        if isinstance(n, yaml.MappingNode):
            out: dict = {}
            lines: dict = {}
            for k_node, v_node in n.value:
                k = loader.construct_object(k_node, deep=True)
                if isinstance(k, list):
                    raise RigInputError(path, k_node.start_mark.line + 1, None, "a key cannot be a list")
                if k in out:
                    raise RigInputError(path, k_node.start_mark.line + 1, str(k), "duplicate key")
                out[k] = build(v_node)
                lines[k] = k_node.start_mark.line + 1
            loc._lines[id(out)] = lines
            loc._own[id(out)] = n.start_mark.line + 1
            loc._keep.append(out)
            return out
        if isinstance(n, yaml.SequenceNode):
            lst = [build(v) for v in n.value]
            loc._lines[id(lst)] = {i: v.start_mark.line + 1 for i, v in enumerate(n.value)}
            loc._own[id(lst)] = n.start_mark.line + 1
            loc._keep.append(lst)
            return lst
        try:
            return loader.construct_object(n, deep=True)
        except yaml.YAMLError as exc:
            problem = getattr(exc, "problem", None) or (str(exc).splitlines() or [""])[0]
            raise RigInputError(path, n.start_mark.line + 1, None, f"not valid YAML: {problem}") from None

    try:
        return build(node), loc
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise RigInputError(path, mark.line + 1 if mark else None, None, f"not valid YAML: {problem}") from None
    finally:
        loader.dispose()
