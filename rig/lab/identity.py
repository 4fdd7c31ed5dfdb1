"""Who and where: the sensor key, the rig's identity and the temperatures of a session manifest.

The manifest is read as plain YAML (``session.yaml``, docs/session-format.md), never through the
typed reader, so the history records sessions of any ``rig-session/1`` writer.
"""

from __future__ import annotations

import json
import math


def _get(d, *keys):
    for k in keys:
        if not isinstance(d, dict):
            return None
        d = d.get(k)
    return d


def _serial(manifest: dict, cal) -> str | None:
    """A serial or fixture id from the manifest (``rig.sensor.serial``, ``sensor_serial``, ``fixture``,
    ``operator.serial``) or the calibration file's ``sensor.serial``."""
    for value in (_get(manifest, "rig", "sensor", "serial"), manifest.get("sensor_serial"), manifest.get("fixture"),
                  _get(manifest, "operator", "serial"), (cal.sensor or {}).get("serial")):
        if value not in (None, ""):
            return str(value)
    return None


def sensor_identity(manifest: dict, cal, sensor_id: str | None = None) -> dict:
    """``{key, model, address, identity, serial}`` of the calibrated sensor.

    The key: ``MODEL:SERIAL`` when a serial or fixture id is known (``sensor_id`` first), else
    ``MODEL@0xADDR#0xID`` from the bus address and the chip's identity register, plus ``/sim-seed-N``
    for a simulated rig (its seed draws the sensor: the same seed is the same simulated sensor).
    """
    sensor = _get(manifest, "rig", "sensor") or {}
    model = sensor.get("model") or (cal.sensor or {}).get("model") or "unknown"
    address = sensor.get("address", (cal.sensor or {}).get("address"))
    identity = sensor.get("identity")
    serial = str(sensor_id) if sensor_id else _serial(manifest, cal)
    if serial is not None:
        key = f"{model}:{serial}"
    else:
        key = str(model)
        if isinstance(address, int):
            key += f"@0x{address:02x}"
        ident = identity.get("identity_value") if isinstance(identity, dict) else identity
        if isinstance(ident, int):
            key += f"#0x{ident:02x}"
        elif ident not in (None, ""):
            key += f"#{ident}"
        if manifest.get("seed") is not None:
            key += f"/sim-seed-{manifest['seed']}"
    return {"key": key, "model": model, "address": address if isinstance(address, int) else None,
            "identity": json.dumps(identity, sort_keys=True, default=str) if identity is not None else None,
            "serial": serial}


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
