"""Calibration errors: each ``str()`` is one line saying what is wrong and what was expected."""

from __future__ import annotations


class CalibError(ValueError):
    """Base class: the input cannot give a trustworthy calibration."""


class ObservabilityError(CalibError):
    """The pose set (or temperature coverage) does not determine the model."""


class CalibrationFileError(CalibError):
    """A calibration file does not validate; names the file and the field."""

    def __init__(self, path, field, expected) -> None:
        self.path, self.field, self.expected = path, field, expected
        where = f"{path}: " if path else ""
        fld = f"{field}: " if field else ""
        super().__init__(f"{where}{fld}{expected}")
