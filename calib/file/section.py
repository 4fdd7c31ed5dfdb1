"""Calibration sections: one base class, subclasses only declare their fields.

The pattern of imucal's ``CalibrationInfo``: :class:`CalibrationSection` (a pydantic v2
model) implements serialisation once (:meth:`~CalibrationSection.to_dict`,
:meth:`~CalibrationSection.from_dict`), validation (the field types of :mod:`calib.file.fields`:
shape, finite, sign) and the units (:meth:`~CalibrationSection.units`, from each field's ``unit``). A
subclass declares ``CAL_TYPE`` (its key in the calibration file) and its fields::

    class MagCalibration(CalibrationSection):
        CAL_TYPE = "magnetometer"
        matrix: Matrix3 = Field(json_schema_extra={"unit": "-"})
        hard_iron_ut: Vector3 = Field(json_schema_extra={"unit": "uT"})

:func:`section_class` dispatches on the type tag. Every validation failure becomes one
:class:`calib.errors.CalibrationFileError` naming the file and the field path
(``gyroscope.bias_pairs[2].bias_counts``), by :func:`calib.file.fields.describe` (the one located-error
function of every format). Cross-field checks (model validators) name their field with
:func:`~calib.file.fields.field_problem`. From a file, an unknown key is refused naming the allowed ones.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from pydantic import (BaseModel, ConfigDict, ValidationError, ValidationInfo, field_validator, model_serializer,
                      model_validator)

from calib.errors import CalibrationFileError
from calib.file.fields import FROM_FILE, check_mapping, describe, fail, field_problem
# the field types the sections declare (calib.file.fields, the dialect of every YAML format)
from calib.file.fields import choice as _choice

#: registry of the file's sections by type tag (``CAL_TYPE``), filled by subclassing
SECTIONS: dict[str, type["CalibrationSection"]] = {}


def choice(*options: str) -> Any:
    """A string field, one of ``options`` (the file's JSON Schema says ``"type": "string"``)."""
    return _choice(options, json_type="string")


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
    def _file_keys(cls, data: Any, info: ValidationInfo) -> Any:
        """From a file: no unknown key (naming the allowed ones), every ``FILE_REQUIRED`` key."""
        if not (info.context and info.context.get("from_file")):
            return data
        data = check_mapping(cls, data, info)
        if isinstance(data, dict):
            for key in cls.FILE_REQUIRED:
                if key not in data:
                    raise fail("missing required field", at=(key,))
        return data

    @classmethod
    def __get_pydantic_json_schema__(cls, core_schema, handler):
        schema = handler(core_schema)
        target = handler.resolve_ref_schema(schema)
        if cls.FILE_REQUIRED:
            target["required"] = list(dict.fromkeys(target.get("required", []) + list(cls.FILE_REQUIRED)))
        return schema

    def to_dict(self) -> dict:
        """Plain floats, ints, strings, lists and dicts (YAML/JSON-friendly); :meth:`from_dict` inverts it exactly."""
        return self.model_dump(by_alias=True)

    @classmethod
    def from_dict(cls, d: Any, path: str | None = None, root: str | None = None, lines=None):
        """Validate and build from :meth:`to_dict` output (an instance is returned as it is).

        Raises
        ------
        CalibrationFileError naming ``path`` (the file, if any; ``path:line`` with the loader's ``lines``),
        the field path (under ``root``, default ``LABEL`` or ``CAL_TYPE``) and what was expected.
        """
        if isinstance(d, cls):
            return d
        try:
            return cls.model_validate(d, context=FROM_FILE)
        except ValidationError as exc:
            label = root if root is not None else (cls.LABEL or cls.CAL_TYPE)
            line, key, message = describe(exc, d, lines, root=label)
            where = None if path is None else f"{path}:{line}" if line else str(path)
            raise CalibrationFileError(where, key, message) from None

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


class WithUncertainty(CalibrationSection):
    """A section that may carry its uncertainty budget (docs/uncertainty.md): the subclass declares ``uncertainty``
    where its file order puts it; it is validated and dumped here, once for every sensor. In a file: None, or a
    mapping with the coverage factor ``k`` (a number > 0) and its ``budget`` (contributions, each of type A or B);
    dumped only when a budget was made, so files and outputs without one are as they were."""

    @model_serializer(mode="wrap")
    def _without_absent_uncertainty(self, handler):
        d = handler(self)
        if isinstance(d, dict) and d.get("uncertainty") is None:
            d.pop("uncertainty", None)
        return d

    @field_validator("uncertainty", mode="before", check_fields=False)
    @classmethod
    def _valid_uncertainty(cls, u: Any) -> Any:
        if u is None:
            return u
        k = u.get("k") if isinstance(u, dict) else None
        if not isinstance(k, (int, float)) or isinstance(k, bool) or not k > 0:
            raise field_problem("k", f"expected the coverage factor, a number > 0, got {k!r}")
        budget = u.get("budget")
        if not isinstance(budget, list) or not all(isinstance(c, dict) and c.get("type") in ("A", "B") for c in budget):
            raise field_problem("budget", "expected a list of contributions, each with type A or B")
        return dict(u)
