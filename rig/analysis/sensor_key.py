"""The sensor's key: who was calibrated, from a session manifest (plain mapping) and optionally its calibration.

``MODEL:SERIAL`` when a serial or fixture id is known, else ``MODEL@0xADDR#0xID`` plus ``/sim-seed-N`` for a
simulated rig. The history files calibrations under it (:mod:`rig.lab.history`) and ``rig compare`` uses it to
say when two sessions are of two different units (docs/history.md, docs/twin.md).
"""

from __future__ import annotations

import json


def _cal_sensor(cal) -> dict:
    """The calibration file's ``sensor`` mapping (empty without a calibration)."""
    return getattr(cal, "sensor", None) or {}


def get_path(d, *keys):
    """``d[k1][k2]...``; None where a key or a mapping is missing."""
    for k in keys:
        if not isinstance(d, dict):
            return None
        d = d.get(k)
    return d


def _serial(manifest: dict, cal) -> str | None:
    """A serial or fixture id from the manifest (``rig.sensor.serial``, ``sensor_serial``, ``fixture``,
    ``operator.serial``) or the calibration file's ``sensor.serial``."""
    for value in (get_path(manifest, "rig", "sensor", "serial"), manifest.get("sensor_serial"), manifest.get("fixture"),
                  get_path(manifest, "operator", "serial"), _cal_sensor(cal).get("serial")):
        if value not in (None, ""):
            return str(value)
    return None


def sensor_identity(manifest: dict, cal, sensor_id: str | None = None) -> dict:
    """``{key, model, address, identity, serial}`` of the calibrated sensor.

    The key: ``MODEL:SERIAL`` when a serial or fixture id is known (``sensor_id`` first), else
    ``MODEL@0xADDR#0xID`` from the bus address and the chip's identity register, plus ``/sim-seed-N``
    for a simulated rig (its seed draws the sensor: the same seed is the same simulated sensor).
    """
    sensor = get_path(manifest, "rig", "sensor") or {}
    model = sensor.get("model") or _cal_sensor(cal).get("model") or "unknown"
    address = sensor.get("address", _cal_sensor(cal).get("address"))
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
