"""Calibration sections: one base class, subclasses only declare their fields.

The pattern of imucal's ``CalibrationInfo``: :class:`CalibrationSection` (a pydantic v2
model) implements serialisation once (:meth:`~CalibrationSection.to_dict`,
:meth:`~CalibrationSection.from_dict`), validation (the field types below: shape, finite,
sign) and the units (:meth:`~CalibrationSection.units`, from each field's ``unit``). A
subclass declares ``CAL_TYPE`` (its key in the calibration file) and its fields::

    class MagCalibration(CalibrationSection):
        CAL_TYPE = "magnetometer"
        matrix: Matrix3 = Field(json_schema_extra={"unit": "-"})
        hard_iron_ut: Vector3 = Field(json_schema_extra={"unit": "uT"})

:func:`section_class` dispatches on the type tag. Every validation failure becomes one
:class:`calib.errors.CalibrationFileError` naming the file and the field path
(``gyroscope.bias_pairs[2].bias_counts``). Cross-field checks (model validators) name their
field with :func:`field_problem`.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, ClassVar

import numpy as np
from pydantic import (BaseModel, BeforeValidator, ConfigDict, Field, PlainSerializer, ValidationError,
                      ValidationInfo, WithJsonSchema, model_validator)

from calib.errors import CalibrationFileError

#: registry of the file's sections by type tag (``CAL_TYPE``), filled by subclassing
SECTIONS: dict[str, type["CalibrationSection"]] = {}


def field_problem(field: str, expected: str) -> ValueError:
    """A ValueError for a model validator that names its (sub-)field: ``raise field_problem("scale", "...")``."""
    return ValueError(f"@{field}@{expected}")


# ---------------------------------------------------------------------------------------------- field types

def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))


def _check_number(x: Any, *, positive: bool, nonneg: bool, allow_nan: bool, optional: bool,
                  null_is_nan: bool) -> float | None:
    if x is None and (optional or null_is_nan):
        return float("nan") if null_is_nan else None
    bound = " > 0" if positive else " >= 0" if nonneg else ""
    if not _is_number(x):
        raise ValueError(f"a number{bound}, got {x!r}"[:200])
    x = float(x)
    if math.isnan(x) and (allow_nan or null_is_nan):
        return x
    if not math.isfinite(x) or (positive and not x > 0) or (nonneg and not x >= 0):
        raise ValueError(f"a finite number{bound}, got {x}")
    return x


def _number_schema(positive: bool, nonneg: bool, nullable: bool) -> dict:
    s: dict = {"type": "number"}
    if positive:
        s["exclusiveMinimum"] = 0
    elif nonneg:
        s["minimum"] = 0
    return {"anyOf": [s, {"type": "null"}]} if nullable else s


def number(*, positive: bool = False, nonneg: bool = False, allow_nan: bool = False, optional: bool = False,
           null_is_nan: bool = False) -> Any:
    """A float field: no booleans, finite (or NaN with ``allow_nan``), optionally > 0 or >= 0.

    ``optional``: None stays None. ``null_is_nan``: NaN in memory, written as null.
    """
    def check(x):
        return _check_number(x, positive=positive, nonneg=nonneg, allow_nan=allow_nan, optional=optional,
                             null_is_nan=null_is_nan)

    def dump(x):
        if x is None or (null_is_nan and math.isnan(x)):
            return None
        return float(x)

    return Annotated[Any, BeforeValidator(check), PlainSerializer(dump),
                     WithJsonSchema(_number_schema(positive, nonneg, optional or null_is_nan))]


def integer(*, minimum: int = 0, maximum: int | None = None) -> Any:
    """An int field (no booleans) in ``[minimum, maximum]``."""
    def check(x):
        ok = isinstance(x, (int, np.integer)) and not isinstance(x, bool) and x >= minimum
        if not ok or (maximum is not None and x > maximum):
            upper = f" and <= {maximum}" if maximum is not None else ""
            raise ValueError(f"an integer >= {minimum}{upper}, got {x!r}")
        return int(x)

    schema = {"type": "integer", "minimum": minimum} | ({"maximum": maximum} if maximum is not None else {})
    return Annotated[Any, BeforeValidator(check), PlainSerializer(int), WithJsonSchema(schema)]


def choice(*options: str) -> Any:
    """A string field, one of ``options``."""
    def check(x):
        if x not in options:
            raise ValueError(f"one of {', '.join(options)}, got {x!r}")
        return str(x)

    return Annotated[Any, BeforeValidator(check), PlainSerializer(str),
                     WithJsonSchema({"type": "string", "enum": list(options)})]


def _check_array(value: Any, shape: tuple, positive: bool, nonneg: bool) -> np.ndarray:
    want = [("N" if n is None else n) for n in shape]
    try:
        flat = np.asarray(value, dtype=object).ravel()
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"a numeric array of shape {want}") from None
    if value is None or isinstance(value, (str, bytes)) or arr.ndim != len(shape) or any(
            n is not None and n != m for n, m in zip(shape, arr.shape)):
        raise ValueError(f"shape {want}, got {list(arr.shape) if value is not None else None}")
    if any(isinstance(x, (bool, np.bool_)) for x in flat):
        raise ValueError("numbers, got true/false")
    text = next((x for x in flat if isinstance(x, (str, bytes))), None)
    if text is not None:
        raise ValueError(f"numbers, got the string {text!r}"[:200])
    if not np.all(np.isfinite(arr)):
        raise ValueError("finite values (no NaN or infinity)")
    if positive and np.any(arr <= 0):
        raise ValueError("values > 0")
    if nonneg and np.any(arr < 0):
        raise ValueError("values >= 0")
    return arr


def _array_schema(shape: tuple, positive: bool, nonneg: bool) -> dict:
    s: dict = {"type": "number"}
    if positive:
        s["exclusiveMinimum"] = 0
    elif nonneg:
        s["minimum"] = 0
    for n in reversed(shape):
        s = {"type": "array", "items": s} | ({} if n is None else {"minItems": n, "maxItems": n})
    return s


def array(*shape: int | None, positive: bool = False, nonneg: bool = False, as_list: bool = False) -> Any:
    """A float array field of ``shape`` (None: any length), finite, optionally > 0 or >= 0.

    A numpy array in memory (a nested list with ``as_list``), a nested list in the file.
    """
    def check(x):
        a = _check_array(x, shape, positive, nonneg)
        return a.tolist() if as_list else a

    return Annotated[Any, BeforeValidator(check), PlainSerializer(lambda a: np.asarray(a, float).tolist()),
                     WithJsonSchema(_array_schema(shape, positive, nonneg))]


def unit(u: str, description: str = "", **kw) -> Any:
    """``Field`` with a unit (``units()``, JSON Schema ``unit``) and a description."""
    return Field(json_schema_extra={"unit": u}, description=description or None, **kw)


Vector3 = array(3)
Matrix3 = array(3, 3)


# ---------------------------------------------------------------------------------------------- base class

def _same(a: Any, b: Any) -> bool:
    """Deep equality of plain data, NaN equal to NaN."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def _location(root: str, loc: tuple) -> str:
    out = root
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif str(part).startswith("function-") or part in ("tagged-union",):
            continue
        else:
            out += f".{part}" if out else str(part)
    return out


def file_error(exc: ValidationError, path: str | None, root: str) -> CalibrationFileError:
    """The first error of a pydantic ValidationError as one-line :class:`CalibrationFileError`."""
    err = exc.errors(include_url=False)[0]
    kind, loc = err["type"], tuple(err["loc"])
    if kind == "missing":
        expected = "missing (required field)"
    elif kind == "extra_forbidden":
        expected = ("unknown field (a typo, or a file written by a newer rig; this reader knows only the "
                    "fields of docs/calibration-file.md)")
    elif kind in ("dict_type", "model_type", "model_attributes_type"):
        expected = "expected a mapping"
    elif kind == "list_type":
        expected = "expected a list"
    elif kind == "value_error":
        expected = str(err["ctx"]["error"])
        if expected.startswith("@"):
            sub, expected = expected[1:].split("@", 1)
            loc = loc + tuple(p if not p.startswith("[") else int(p[1:-1]) for p in _split(sub))
    else:
        expected = err["msg"]
    return CalibrationFileError(path, _location(root, loc) or None, expected.replace("\n", " "))


def _split(sub: str) -> list[str]:
    parts: list[str] = []
    for chunk in sub.split("."):
        head, _, rest = chunk.partition("[")
        if head:
            parts.append(head)
        if rest:
            parts.append("[" + rest)
    return parts


class CalibrationSection(BaseModel):
    """Base of every section of the calibration file: fields declared by subclasses, the rest here.

    Class attributes
    ----------------
    CAL_TYPE : the section's key in the calibration file (``"gyroscope"``); "" for sub-sections.
    LABEL : the root of the field path in errors when the section is validated alone (default CAL_TYPE).
    FILE_REQUIRED : fields with a default in memory that a file must contain all the same.
    """

    CAL_TYPE: ClassVar[str] = ""
    LABEL: ClassVar[str] = ""
    FILE_REQUIRED: ClassVar[tuple[str, ...]] = ()

    model_config = ConfigDict(arbitrary_types_allowed=True, validate_by_name=True, validate_by_alias=True,
                              extra="forbid")

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs: Any) -> None:
        super().__pydantic_init_subclass__(**kwargs)
        if cls.__dict__.get("CAL_TYPE"):
            SECTIONS[cls.CAL_TYPE] = cls

    @model_validator(mode="before")
    @classmethod
    def _file_required(cls, data: Any, info: ValidationInfo) -> Any:
        if info.context and info.context.get("file") and isinstance(data, dict):
            for key in cls.FILE_REQUIRED:
                if key not in data:
                    raise field_problem(key, "missing (required field)")
        return data

    @classmethod
    def __get_pydantic_json_schema__(cls, core_schema, handler):  # noqa: ANN001 (pydantic hook)
        schema = handler(core_schema)
        target = handler.resolve_ref_schema(schema)
        if cls.FILE_REQUIRED:
            target["required"] = list(dict.fromkeys(target.get("required", []) + list(cls.FILE_REQUIRED)))
        return schema

    def to_dict(self) -> dict:
        """Plain floats, ints, strings, lists and dicts (YAML/JSON-friendly); :meth:`from_dict` inverts it exactly."""
        return self.model_dump(by_alias=True)

    @classmethod
    def from_dict(cls, d: Any, path: str | None = None, root: str | None = None):
        """Validate and build from :meth:`to_dict` output (an instance is returned as it is).

        Raises
        ------
        CalibrationFileError naming ``path`` (the file, if any), the field path (under ``root``,
        default ``LABEL`` or ``CAL_TYPE``) and what was expected.
        """
        if isinstance(d, cls):
            return d
        try:
            return cls.model_validate(d, context={"file": True})
        except ValidationError as exc:
            label = root if root is not None else (cls.LABEL or cls.CAL_TYPE)
            raise file_error(exc, None if path is None else str(path), label) from None

    @classmethod
    def units(cls) -> dict[str, str]:
        """Unit of every field that declares one (``{"bias_counts": "counts", ...}``)."""
        out = {}
        for name, f in cls.model_fields.items():
            extra = f.json_schema_extra if isinstance(f.json_schema_extra, dict) else {}
            if "unit" in extra:
                out[f.alias or name] = str(extra["unit"])
        return out

    @classmethod
    def json_schema(cls) -> dict:
        """JSON Schema (draft 2020-12) of the section as it appears in the file."""
        return cls.model_json_schema(by_alias=True, mode="validation")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, CalibrationSection):
            return NotImplemented
        return type(self) is type(other) and _same(self.to_dict(), other.to_dict())

    __hash__ = None  # type: ignore[assignment]  (arrays inside: not hashable)


def section_class(cal_type: str) -> type[CalibrationSection]:
    """The section class of a type tag (``"accelerometer"``, ``"gyroscope"``, ``"magnetometer"``)."""
    return SECTIONS[cal_type]
