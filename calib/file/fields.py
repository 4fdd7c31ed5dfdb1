"""The field dialect of every YAML format: field types, mapping models and the one-line located error.

One dialect for the procedure and rig-file schemas (``rig.config``), the calibration file's sections
(:mod:`calib.file.section`) and the session manifest (``rig.session.manifest``):

- field types built by small factories (:func:`number`, :func:`integer`, :func:`choice`, :func:`flag`,
  :func:`text`, :func:`label`, :func:`array`) whose validators say what was expected and what was
  given (``expected a number > 0, got -1``) and whose JSON Schema says the same bounds;
- :class:`Strict`, a frozen model of one mapping that refuses an unknown key naming the allowed ones
  and the likeliest one meant (:func:`check_mapping` for other models; :func:`did_you_mean`);
- :func:`fail` (and :func:`field_problem`) for a validator's own message, located below the value it checks;
- :func:`describe`, the one function that turns a pydantic ValidationError (with the YAML loader's
  :class:`~calib.file.yamlsafe.LineMap`, when there is one) into the parts of the one line
  ``file:line: key.path: what was expected``: the error's ``loc`` is walked through the document
  (pydantic's own segments, such as union members, are not keys of the document and are skipped).
"""

from __future__ import annotations

import difflib
import math
import numbers
import re
from typing import Annotated, Any, ClassVar, NamedTuple

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, PlainSerializer, ValidationError, WithJsonSchema
from pydantic import model_validator
from pydantic_core import ArgsKwargs, PydanticCustomError

#: validation context of a document read from a file (internal fields are refused there)
FROM_FILE = {"from_file": True}
_FAIL = "expected"  # the error type of fail()


def fail(message: str, at: tuple = ()) -> PydanticCustomError:
    """A validation error with the dialect's message; ``at`` locates it below the failing value
    (keys, and :class:`Index` for list positions)."""
    return PydanticCustomError(_FAIL, "{message}", {"message": message, "at": tuple(at)})


def field_problem(field: str, expected: str) -> PydanticCustomError:
    """:func:`fail` located at the (sub-)field path ``field`` (``"scale"``, ``"bias_pairs[2].bias_counts"``,
    ``"[3]"``): ``raise field_problem("scale", "must equal the diagonal of matrix")`` in a model validator."""
    at: list = []
    for chunk in field.split("."):
        head, *indexes = chunk.split("[")
        if head:
            at.append(head)
        at.extend(Index(int(i.rstrip("]"))) for i in indexes)
    return fail(expected, at=tuple(at))


def got(v) -> str:
    """A given value as a message shows it (``repr``, at most 60 characters)."""
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def fmt(x) -> str:
    """A bound as people write it: 86400000, 0.5, 1e+300."""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


# -- mappings ----------------------------------------------------------------------------------------
def yaml_keys(cls) -> list[str]:
    """The keys a file may give for model ``cls``: aliases (and names, when the model validates by name);
    internal fields and fields never written excluded."""
    internal = getattr(cls, "internal_keys", frozenset())
    config = getattr(cls, "model_config", {})
    by_name = bool(config.get("validate_by_name") or config.get("populate_by_name"))
    keys = []
    for name, f in cls.__pydantic_fields__.items():
        if name not in internal and f.exclude is not True:
            keys += [f.alias or name] + ([name] if by_name and f.alias and f.alias != name else [])
    return keys


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
            raise fail(f"unknown key (allowed: {', '.join(sorted(allowed))}){did_you_mean(key, allowed)}", at=(key,))
    return data


def did_you_mean(word, choices) -> str:
    """``: did you mean 'dwell'?`` for the choice closest to a misspelt ``word`` (difflib, ratio >= 0.6, case
    ignored); empty when none is close. Appended to a message that names the allowed choices."""
    if not isinstance(word, str):
        return ""
    folded = {str(c).casefold(): str(c) for c in choices}
    close = difflib.get_close_matches(word.casefold(), list(folded), n=1)
    return f": did you mean {folded[close[0]]!r}?" if close else ""


class Strict(BaseModel):
    """A frozen model of one YAML mapping: unknown keys refused, the dialect's messages."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    mapping_hint: ClassVar[str] = "expected a mapping"
    refused_keys: ClassVar[dict[str, str]] = {}

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data, info):
        return check_mapping(cls, data, info)


# -- scalar field types ----------------------------------------------------------------------------
def _real(v) -> bool:
    """A number: int, float or a numpy number (never a bool)."""
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def _finite(v) -> bool:
    try:
        return math.isfinite(v)
    except OverflowError:  # an int beyond any float
        return False


#: a decimal number in exponent form: ``1e3``, ``1.0e9``, ``-2.5E-3``, ``.5e2``. YAML 1.1 (PyYAML's resolver)
#: reads a float only with a dot and a signed exponent (``1.0e+9``), so these arrive as strings; a field that
#: expects a number takes them as the number they write (no underscores, no hex, no inf or nan: those are not
#: numbers people write by accident, and stay refused)
_EXPONENT_FORM = re.compile(r"[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[eE][-+]?[0-9]+\Z")


def as_number(v):
    """``v`` as a number field reads it: a string in exponent form (:data:`_EXPONENT_FORM`) becomes its float,
    anything else is ``v`` unchanged. The one place that decides which strings are numbers."""
    if isinstance(v, str) and len(v) <= 64 and _EXPONENT_FORM.match(v):
        return float(v)
    return v


def number(*, gt=None, ge=None, lt=None, le=None, integer=False, positive=False, nonneg=False,
           optional=False, allow_nan=False, null_is_nan=False, finite=True, keep_type=False, too_big: str | None = None,
           in_range: bool = False, description: str | None = None):
    """A finite number (bool refused) within bounds; ``integer``: a whole number (2.0 is taken as 2).

    ``positive``/``nonneg``: ``gt=0``/``ge=0``. ``optional``: null stays None. ``allow_nan``: NaN too. ``null_is_nan``:
    NaN in memory, null in the file. ``finite=False``: infinities and NaN too. ``keep_type``: an int stays an int and a
    float a float (the JSON Schema is pydantic's for ``float | int``). ``too_big``: message template for ``le``
    (``{le}``, ``{got}``); ``in_range``: one message ``expected a number in [ge, le]``. A string in exponent form
    (``1.0e9``: YAML 1.1 leaves it a string) is the number it writes (:func:`as_number`), shown as written.
    """
    gt = 0 if positive and gt is None else gt
    ge = 0 if nonneg and ge is None else ge
    kind = "whole number" if integer else "number"

    def check(v):
        if v is None and (optional or null_is_nan):
            return float("nan") if null_is_nan else None
        written, v = v, as_number(v)
        shown = written if v is not written else got(v)  # as the file writes it: 1.0e9, not '1.0e9'
        if (allow_nan or null_is_nan) and _real(v) and not isinstance(v, numbers.Integral) and math.isnan(v):
            return float("nan")
        ok_type = _real(v) and (_finite(v) or not finite)
        if in_range and not (ok_type and ge <= v <= le):
            raise fail(f"expected a number in [{fmt(ge)}, {fmt(le)}], got {shown}")
        if not ok_type:
            raise fail(f"expected a {kind}, got {shown}")
        if integer and not isinstance(v, numbers.Integral) and not float(v).is_integer():
            raise fail(f"expected a whole number, got {shown}")  # (float(2**63 - 1) != 2**63 - 1)
        if gt is not None and v <= gt:
            raise fail(f"expected a number > {fmt(gt)}, got {shown}")
        if ge is not None and v < ge:
            raise fail(f"expected >= {fmt(ge)}, got {shown}")
        if lt is not None and v >= lt:
            raise fail(f"expected < {fmt(lt)}, got {shown}")
        if le is not None and v > le:
            raise fail((too_big or "expected <= {le}, got {got}").format(le=f"{fmt(le)}", got=shown))
        if keep_type:
            return v
        return int(v) if integer else float(v)

    nullable = optional or null_is_nan
    if keep_type:
        return Annotated[(float | int | None) if nullable else (float | int), BeforeValidator(check)]

    def dump(x):
        if x is None or (null_is_nan and math.isnan(x)):
            return None
        return int(x) if integer else float(x)

    schema: dict[str, Any] = {"type": "integer" if integer else "number"}
    for key, val in (("exclusiveMinimum", gt), ("minimum", ge), ("exclusiveMaximum", lt), ("maximum", le)):
        if val is not None:
            schema[key] = val
    if description:
        schema["description"] = description
    if nullable:
        schema = {"anyOf": [schema, {"type": "null"}]}
    base = Any if nullable else int if integer else float
    return Annotated[base, BeforeValidator(check), PlainSerializer(dump), WithJsonSchema(schema)]


def integer(minimum: int = 0, maximum: int | None = None, description: str | None = None):
    """A whole number in ``[minimum, maximum]``."""
    return number(ge=minimum, le=maximum, integer=True, description=description)


def choice(values: tuple, message: str | None = None, description: str | None = None, *,
           json_type: str | None = None):
    """One of ``values`` (bool never equals 1); ``message`` may use ``{got}``; a misspelt text gets the
    closest value after it (``: did you mean 'pinv'?``, :func:`did_you_mean`). ``json_type``: the JSON
    Schema's ``type`` beside the ``enum`` (``"string"``), when the published schema says it."""
    values = tuple(values)

    def check(v):
        if isinstance(v, bool) or isinstance(v, (list, dict)) or v not in values:
            default = f"expected one of {', '.join(map(str, values))}, got {{got}}"
            raise fail((message or default).format(got=got(v)) + did_you_mean(v, values))
        return values[values.index(v)]

    schema: dict[str, Any] = {"enum": list(values)}
    if json_type:
        schema["type"] = json_type
    if description:
        schema["description"] = description
    return Annotated[Any, BeforeValidator(check), WithJsonSchema(schema)]


def flag(description: str | None = None):
    """true or false."""

    def check(v):
        if not isinstance(v, bool):
            raise fail(f"expected true or false, got {got(v)}")
        return v

    schema: dict[str, Any] = {"type": "boolean"}
    if description:
        schema["description"] = description
    return Annotated[bool, BeforeValidator(check), WithJsonSchema(schema)]


def text(max_length: int = 2000, description: str | None = None):
    """A non-empty string (stripped)."""

    def check(v):
        if not isinstance(v, str) or not v.strip():
            raise fail(f"expected a non-empty string, got {got(v)}")
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
            raise fail(f"expected a text, got {got(v)}")
        if not blank and not str(v).strip():
            raise fail(f"expected a non-empty name, got {got(v)}")
        if len(str(v)) > max_length:
            raise fail(f"expected at most {max_length} characters, got {len(str(v))}")
        return str(v)

    schema: dict[str, Any] = {"type": ["string", "number"]}
    if description:
        schema["description"] = description
    return Annotated[str, BeforeValidator(check), WithJsonSchema(schema)]


# -- arrays --------------------------------------------------------------------------------------------
def _check_array(value: Any, shape: tuple, positive: bool, nonneg: bool) -> np.ndarray:
    want = [("N" if n is None else n) for n in shape]
    try:
        flat = np.asarray(value, dtype=object).ravel()
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise fail(f"expected a numeric array of shape {want}") from None
    if value is None or isinstance(value, (str, bytes)) or arr.ndim != len(shape) or any(
            n is not None and n != m for n, m in zip(shape, arr.shape)):
        raise fail(f"expected shape {want}, got {list(arr.shape) if value is not None else None}")
    if any(isinstance(x, (bool, np.bool_)) for x in flat):
        raise fail("expected numbers, got true/false")
    text_ = next((x for x in flat if isinstance(x, (str, bytes))), None)
    if text_ is not None:
        raise fail(f"expected numbers, got the string {got(text_)}")
    if not np.all(np.isfinite(arr)):
        raise fail("expected finite values (no NaN or infinity)")
    if positive and np.any(arr <= 0):
        raise fail("expected values > 0")
    if nonneg and np.any(arr < 0):
        raise fail("expected values >= 0")
    return arr


def array(*shape: int | None, positive: bool = False, nonneg: bool = False, as_list: bool = False) -> Any:
    """A float array of ``shape`` (None: any length), finite, optionally > 0 or >= 0: a numpy array in
    memory (a nested list with ``as_list``), a nested list in the file."""
    def check(x):
        a = _check_array(x, shape, positive, nonneg)
        return a.tolist() if as_list else a

    s: dict = {"type": "number"}
    if positive:
        s["exclusiveMinimum"] = 0
    elif nonneg:
        s["minimum"] = 0
    for n in reversed(shape):
        s = {"type": "array", "items": s} | ({} if n is None else {"minItems": n, "maxItems": n})
    return Annotated[Any, BeforeValidator(check), PlainSerializer(lambda a: np.asarray(a, float).tolist()),
                     WithJsonSchema(s)]


def unit(u: str, description: str = "", **kw) -> Any:
    """``Field`` with a unit (JSON Schema ``unit``) and a description."""
    return Field(json_schema_extra={"unit": u}, description=description or None, **kw)


Vector3 = array(3)
Matrix3 = array(3, 3)


# -- a validation error -> one located line ---------------------------------------------------------
class Index(int):
    """A list position in a key path (``steps[3]``), unlike an integer mapping key (``axes.3``)."""


def key_path(parts, root: str = "") -> str:
    """``steps[3].pose`` from ("steps", Index(3), "pose"); ``root`` goes first (``gyro.sigma``)."""
    out = root
    for p in parts:
        out += f"[{p}]" if isinstance(p, Index) else (f".{p}" if out else str(p))
    return out


class Problem(NamedTuple):
    """The parts of one line ``file:line: key: message``: ``line`` 1-based or None, ``key`` a key path or None."""

    line: int | None
    key: str | None
    message: str


class _NoLines:
    def line_of(self, container, key=None):
        return None


def describe(error, doc, lines=None, *, prefix: tuple = (), root: str = "") -> Problem:
    """The first problem of ``error`` (a pydantic ValidationError, or one of its ``errors()``) as
    (line, key path, message).

    ``doc`` is the document validated (or, with ``prefix``, the document whose ``doc[prefix...]`` was);
    ``lines`` the loader's :class:`~calib.file.yamlsafe.LineMap` (None: no lines); ``root`` goes before
    the key path (``gyro.sigma.m_zy``) when the value was validated alone.
    """
    err = error.errors(include_url=False)[0] if isinstance(error, ValidationError) else error
    lines = lines if lines is not None else _NoLines()
    ctx = err.get("ctx") or {}
    loc = tuple(err["loc"])
    missing = loc[-1] if err["type"] == "missing" and loc else None
    cur, container, key, parts = doc, None, None, []
    for e in list(prefix) + list(loc[:-1] if missing is not None else loc):  # what is not in doc: pydantic's
        if isinstance(cur, list) and isinstance(e, int) and 0 <= e < len(cur):
            container, key, cur = cur, e, cur[e]
            parts.append(Index(e))
        elif isinstance(cur, dict) and not isinstance(e, int) and e in cur:
            container, key, cur = cur, e, cur[e]
            parts.append(e)
    for e in ctx.get("at", ()):  # below the failing value; may name a key the document lacks
        if isinstance(cur, dict) and e in cur:
            container, key, cur = cur, e, cur[e]
            parts.append(e)
        elif isinstance(cur, list) and isinstance(e, int) and 0 <= e < len(cur):
            container, key, cur = cur, e, cur[e]
            parts.append(Index(e))
        else:
            cur = None
            parts.append(e)
    if container is None:
        line = lines.line_of(doc) if isinstance(doc, (dict, list)) else None
    else:
        line = lines.line_of(container, key)
    if missing is not None:  # the line of the mapping that lacks the key
        line = lines.line_of(cur) if isinstance(cur, (dict, list)) else line
        parts.append(Index(missing) if isinstance(missing, int) else missing)
        message = "missing required field"
    else:
        message = _message(err)
    # one line; a value's own spaces are kept (got '   ')
    return Problem(line, key_path(parts, root) or None, re.sub(r"\s*\n\s*", " ", message).strip())


_GENERIC = {
    "model_type": "expected a mapping", "dataclass_type": "expected a mapping", "dict_type": "expected a mapping",
    "model_attributes_type": "expected a mapping", "typed_dict_type": "expected a mapping",
    "list_type": "expected a list", "tuple_type": "expected a list",
    "string_type": "expected a string", "bool_type": "expected true or false", "bool_parsing": "expected true or false",
    "int_type": "expected a whole number", "int_parsing": "expected a whole number",
    "int_from_float": "expected a whole number", "float_type": "expected a number", "float_parsing": "expected a number",
    "finite_number": "expected a finite number", "none_required": "expected null",
}
_BOUNDS = {"greater_than": ("gt", "a number > "), "greater_than_equal": ("ge", ">= "),
           "less_than": ("lt", "< "), "less_than_equal": ("le", "<= ")}


def _message(err: dict) -> str:
    ctx = err.get("ctx") or {}
    kind = err["type"]
    if kind == _FAIL:
        return str(ctx["message"])
    if kind in ("value_error", "assertion_error") and "error" in ctx:  # a validator's own ValueError
        return (str(ctx["error"]).splitlines() or ["invalid"])[0]
    if kind in _GENERIC:
        return f"{_GENERIC[kind]}, got {got(err.get('input'))}"
    if kind in _BOUNDS:
        name, text_ = _BOUNDS[kind]
        return f"expected {text_}{fmt(ctx[name])}, got {got(err.get('input'))}"
    if kind in ("literal_error", "enum"):  # ctx: "'a', 'b' or 'c'"
        allowed = str(ctx.get("expected", "")).replace(" or ", ", ").replace("'", "")
        return f"expected one of {allowed}, got {got(err.get('input'))}" + did_you_mean(err.get("input"),
                                                                                         allowed.split(", "))
    if kind == "extra_forbidden":
        return "unknown key"
    if kind in ("too_short", "too_long"):
        return (f"expected {ctx.get('min_length', ctx.get('max_length'))} items or "
                f"{'more' if kind == 'too_short' else 'fewer'}")
    return (str(err.get("msg")).splitlines() or ["invalid"])[0]
