"""Shared pieces of the ``rig-procedure/1`` and ``rig-file/1`` schemas (pydantic v2).

Field types are built by small factories (:func:`number`, :func:`choice`, :func:`flag`,
:func:`text`, :func:`label`) whose validators speak the house style (``expected a number > 0,
got -1``) and whose JSON Schema says the same bounds. Every model derives from
:class:`Strict` (or uses :func:`strict_keys` for pydantic dataclasses): a mapping with an
unknown key is refused naming the key and the allowed ones.

:func:`validate_located` runs a model on a YAML document and turns the first pydantic error
into a one-line :class:`~rig.errors.RigInputError` ``file:line: key.path: message``: the
error's ``loc`` is walked through the document (pydantic's own segments, such as union tags,
are skipped because they are not keys of the document) and the line comes from the loader's
:class:`~rig.config.yamlload.Located` marks.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, ClassVar

from pydantic import BaseModel, BeforeValidator, ConfigDict, TypeAdapter, ValidationError, WithJsonSchema
from pydantic import model_validator
from pydantic_core import ArgsKwargs, PydanticCustomError

from rig.config.yamlload import load_located
from rig.errors import RigInputError

#: validation context of a document read from a file (internal fields are refused there)
FROM_FILE = {"from_file": True}


def fail(message: str, at: tuple = ()) -> PydanticCustomError:
    """A validation error with the house message; ``at`` locates it below the failing value."""
    return PydanticCustomError("rig", "{message}", {"message": message, "at": tuple(at)})


# -- mappings ----------------------------------------------------------------------------------------
def yaml_keys(cls) -> list[str]:
    """The keys a file may give for model ``cls`` (aliases; internal fields excluded)."""
    internal = getattr(cls, "internal_keys", frozenset())
    return [f.alias or name for name, f in cls.__pydantic_fields__.items() if name not in internal]


def check_mapping(cls, data, info):
    """Before-validator body: ``data`` must be a mapping whose keys ``cls`` knows."""
    if isinstance(data, (ArgsKwargs, BaseModel)) or (not isinstance(data, dict) and hasattr(data, "__dataclass_fields__")):
        return data
    if not isinstance(data, dict):
        raise fail(getattr(cls, "mapping_hint", "expected a mapping"))
    from_file = bool(info.context and info.context.get("from_file"))
    allowed = yaml_keys(cls) if from_file else list(cls.__pydantic_fields__)
    refused = getattr(cls, "refused_keys", {})
    for key in data:
        if key in refused:
            raise fail(refused[key], at=(key,))
        if key not in allowed:
            raise fail(f"unknown key (allowed: {', '.join(sorted(allowed))})", at=(key,))
    return data


class Strict(BaseModel):
    """A frozen model of one YAML mapping: unknown keys refused, house-style messages."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    mapping_hint: ClassVar[str] = "expected a mapping"
    refused_keys: ClassVar[dict[str, str]] = {}

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data, info):
        return check_mapping(cls, data, info)


# -- scalar field types ----------------------------------------------------------------------------
def _got(v) -> str:
    return repr(v)


def fmt(x) -> str:
    """A bound as people write it: 86400000, 0.5, 1e+300."""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


def number(*, gt=None, ge=None, lt=None, le=None, integer=False, too_big: str | None = None,
           in_range: bool = False, description: str | None = None):
    """A finite number (bool refused) with bounds; ``integer`` also takes 2.0 as 2.

    ``too_big``: message template for ``le`` (``{le}``, ``{got}``); ``in_range``: one message
    ``expected a number in [ge, le]`` for every failure.
    """
    kind = "whole number" if integer else "number"

    def check(v):
        ok_type = not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)
        if in_range and not (ok_type and ge <= v <= le):
            raise fail(f"expected a number in [{fmt(ge)}, {fmt(le)}], got {_got(v)}")
        if not ok_type:
            raise fail(f"expected a {kind}, got {_got(v)}")
        if integer and isinstance(v, float) and not v.is_integer():  # (float(2**63 - 1) != 2**63 - 1)
            raise fail(f"expected a whole number, got {_got(v)}")
        if gt is not None and v <= gt:
            raise fail(f"expected a number > {fmt(gt)}, got {_got(v)}")
        if ge is not None and v < ge:
            raise fail(f"expected >= {fmt(ge)}, got {_got(v)}")
        if lt is not None and v >= lt:
            raise fail(f"expected < {fmt(lt)}, got {_got(v)}")
        if le is not None and v > le:
            raise fail((too_big or "expected <= {le}, got {got}").format(le=f"{fmt(le)}", got=_got(v)))
        return int(v) if integer else float(v)

    schema: dict[str, Any] = {"type": "integer" if integer else "number"}
    for key, val in (("exclusiveMinimum", gt), ("minimum", ge), ("exclusiveMaximum", lt), ("maximum", le)):
        if val is not None:
            schema[key] = val
    if description:
        schema["description"] = description
    return Annotated[int if integer else float, BeforeValidator(check), WithJsonSchema(schema)]


def choice(values: tuple, message: str | None = None, description: str | None = None):
    """One of ``values`` (bool never equals 1); ``message`` may use ``{got}``."""

    def check(v):
        if isinstance(v, bool) or v not in values or isinstance(v, (list, dict)):
            default = f"expected one of {', '.join(map(str, values))}, got {{got}}"
            raise fail((message or default).format(got=_got(v)))
        return values[values.index(v)]

    schema: dict[str, Any] = {"enum": list(values)}
    if description:
        schema["description"] = description
    return Annotated[Any, BeforeValidator(check), WithJsonSchema(schema)]


def flag(description: str | None = None):
    """true or false."""

    def check(v):
        if not isinstance(v, bool):
            raise fail(f"expected true or false, got {_got(v)}")
        return v

    schema: dict[str, Any] = {"type": "boolean"}
    if description:
        schema["description"] = description
    return Annotated[bool, BeforeValidator(check), WithJsonSchema(schema)]


def text(max_length: int = 2000, description: str | None = None):
    """A non-empty string (stripped)."""

    def check(v):
        if not isinstance(v, str) or not v.strip():
            raise fail(f"expected a non-empty string, got {_got(v)}")
        if len(v) > max_length:
            raise fail(f"expected at most {max_length} characters, got {len(v)}")
        return v.strip()

    schema: dict[str, Any] = {"type": "string", "minLength": 1, "maxLength": max_length}
    if description:
        schema["description"] = description
    return Annotated[str, BeforeValidator(check), WithJsonSchema(schema)]


def label(max_length: int = 200, description: str | None = None, blank: bool = True):
    """A name: a string, or a number taken as its text; ``blank=False`` refuses an empty or blank one."""

    def check(v):
        if isinstance(v, bool) or not isinstance(v, (str, int, float)):
            raise fail(f"expected a text, got {_got(v)}")
        if not blank and not str(v).strip():
            raise fail(f"expected a non-empty name, got {_got(v)}")
        if len(str(v)) > max_length:
            raise fail(f"expected at most {max_length} characters, got {len(str(v))}")
        return str(v)

    schema: dict[str, Any] = {"type": ["string", "number"]}
    if description:
        schema["description"] = description
    return Annotated[str, BeforeValidator(check), WithJsonSchema(schema)]


# -- errors -> one located line --------------------------------------------------------------------
_ADAPTERS: dict[Any, TypeAdapter] = {}


def adapter(model) -> TypeAdapter:
    if model not in _ADAPTERS:
        _ADAPTERS[model] = TypeAdapter(model)
    return _ADAPTERS[model]


def validate_document(model, text: str, path: str, expected: str):
    """Parse YAML ``text`` (the hostile-YAML guards) and validate the whole document as ``model``;
    return (document, line marks, validated model). ``expected`` says what the top level must be."""
    doc, loc = load_located(text, path)
    if not isinstance(doc, dict):
        raise RigInputError(path, 1, None, expected)
    return doc, loc, validate_located(model, doc, path=path, loc=loc)


def validate_located(model, value, *, path: str, loc, doc=None, prefix: tuple = ()):
    """Validate ``value`` (``doc`` walked along ``prefix`` gives it) as ``model``; errors become one line."""
    try:
        return adapter(model).validate_python(value, context=FROM_FILE)
    except ValidationError as exc:
        raise located_error(exc.errors()[0], value if doc is None else doc, path, loc, prefix) from None


class _NoLines:
    def line_of(self, container, key=None):
        return None


def validate_plain(model, value, where: str):
    """Validate ``value`` (not from a file: no lines) as ``model``; errors name ``where.key.path``."""
    try:
        return adapter(model).validate_python(value)
    except ValidationError as exc:
        err = located_error(exc.errors()[0], value, None, _NoLines())
        raise RigInputError(None, None, f"{where}.{err.key}" if err.key else where, err.message) from None


def located_error(err: dict, doc, path: str, loc, prefix: tuple = ()) -> RigInputError:
    """One pydantic error as ``file:line: key.path: message``."""
    ctx = err.get("ctx") or {}
    missing = err["loc"][-1] if err["type"] == "missing" and err["loc"] else None
    elems = list(prefix) + list(err["loc"][:-1] if missing is not None else err["loc"])
    cur, container, key, parts = doc, None, None, []
    for e in elems:
        if isinstance(cur, list) and isinstance(e, int) and 0 <= e < len(cur):
            container, key, cur = cur, e, cur[e]
            parts.append(Index(e))
        elif isinstance(cur, dict) and not isinstance(e, int) and e in cur:
            container, key, cur = cur, e, cur[e]
            parts.append(e)
    for e in ctx.get("at", ()):  # below the failing value; may name a key the document lacks
        if isinstance(cur, dict) and e in cur:
            container, key, cur = cur, e, cur[e]
        else:
            cur = None
        parts.append(e)
    if container is None:
        line = loc.line_of(doc) if isinstance(doc, (dict, list)) else None
    else:
        line = loc.line_of(container, key)
    if missing is not None:
        line = loc.line_of(cur) if isinstance(cur, (dict, list)) else line
        message = f"missing required key {missing!r}"
        parts = parts or [missing]
    else:
        message = _message(err)
    return RigInputError(path, line or (1 if path else None), key_path(parts) or None, message)


class Index(int):
    """A list position in a key path (``steps[3]``), unlike an integer mapping key (``axes.3``)."""


def key_path(parts) -> str:
    """``steps[3].pose`` from ("steps", Index(3), "pose")."""
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, Index) else (f".{p}" if out else str(p))
    return out


_GENERIC = {
    "model_type": "expected a mapping", "dataclass_type": "expected a mapping", "dict_type": "expected a mapping",
    "model_attributes_type": "expected a mapping", "list_type": "expected a list", "tuple_type": "expected a list",
    "string_type": "expected a string", "bool_type": "expected true or false", "int_type": "expected a whole number",
    "float_type": "expected a number", "extra_forbidden": "unknown key", "none_required": "expected null",
}


def _message(err: dict) -> str:
    ctx = err.get("ctx") or {}
    if err["type"] == "rig":
        return str(ctx["message"])
    if err["type"] in _GENERIC:
        return f"{_GENERIC[err['type']]}, got {_got(err.get('input'))}"
    if err["type"] in ("too_short", "too_long"):
        return f"expected {ctx.get('min_length', ctx.get('max_length'))} items or {'more' if err['type'] == 'too_short' else 'fewer'}"
    return (str(err.get("msg")).splitlines() or ["invalid"])[0]
