"""Who and where: the sensor key (:mod:`rig.analysis.sensor_key`, which ``rig compare`` shares), the rig's
identity and the temperatures of a session manifest.

The manifest is read as plain YAML (``session.yaml``, docs/session-format.md), never through the
typed reader, so the history records sessions of any ``rig-session/1`` writer.
"""

from __future__ import annotations

import math

from rig.analysis.sensor_key import get_path as _get
from rig.analysis.sensor_key import sensor_identity

__all__ = ["rig_identity", "sensor_identity", "temperatures"]


def rig_identity(manifest: dict) -> dict:
    """The turntable: kind and, per axis, controller serial and firmware (``rig.turntable.axes``)."""
    table = _get(manifest, "rig", "turntable") or {}
    axes = table.get("axes") or {}
    return {"kind": table.get("kind") or _get(manifest, "rig", "kind"),
            "axes": {name: {"serial": (a or {}).get("serial"), "firmware": (a or {}).get("firmware")}
                     for name, a in sorted(axes.items())}}


def temperatures(manifest: dict) -> tuple[float | None, float | None, float | None]:
    """(mean, min, max) of the steps' mean temperatures, C; None without a thermometer."""
    values = []
    for step in manifest.get("steps") or []:
        t = _get(step, "stats", "temp_c")
        if isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t):
            values.append(float(t))
    if not values:
        return None, None, None
    return sum(values) / len(values), min(values), max(values)
