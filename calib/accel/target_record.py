"""What a calibration file records of its procedure's accuracy target (``target:`` of
``rig-calibration/1``; docs/procedures.md, "Accuracy targets").

A leaf module (pydantic and typing only) so that :mod:`calib.file.calibration` can type the section
without importing the prediction; :func:`calib.accel.predict.target_record` produces the dict.
"""

from __future__ import annotations

from typing import Literal, Optional, Union

from pydantic import ConfigDict, FiniteFloat, StrictBool, with_config
from typing_extensions import TypedDict


@with_config(ConfigDict(extra="forbid"))
class SigmaTargetRecord(TypedDict):
    """One per-parameter sigma target: the limit and the predicted 1-sigma (the parameter's unit)."""

    parameter: str
    target: FiniteFloat
    predicted: FiniteFloat


@with_config(ConfigDict(extra="forbid"))
class TargetRecord(TypedDict):
    """The procedure's target and whether the calibration meets it.

    ``attitude_error_deg`` / ``confidence`` / ``poses``: the attitude target (largest |roll| or |pitch|
    error over the verification poses, ``seed_table`` or ``[a1, a2, a3]`` lists) with
    ``predicted_attitude_error_deg`` its prediction from the recorded steps' standard errors;
    ``sigma``: the per-parameter targets; ``met``: every target predicted met; ``max_seconds`` the
    time cap and ``rig_time_s`` the session time at the end of the last pose; ``summary`` one line.
    """

    met: StrictBool
    attitude_error_deg: Optional[FiniteFloat]
    confidence: Optional[FiniteFloat]
    poses: Union[Literal["seed_table"], list[list[FiniteFloat]]]
    predicted_attitude_error_deg: Optional[FiniteFloat]
    sigma: list[SigmaTargetRecord]
    max_seconds: FiniteFloat
    rig_time_s: Optional[FiniteFloat]
    summary: str
