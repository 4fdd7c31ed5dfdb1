"""What the tests that write a session directly share (no simulator): the manifest of static steps at known faces."""

from __future__ import annotations

#: the MPU-9150 as rig run records it (the sensor section of a session manifest)
MPU9150 = {"model": "MPU-9150", "address": 104, "serial": "T1", "accel_lsb_per_g": 8192.0, "sample_rate_hz": 100.0,
           "has_temperature": True}


def faces_manifest(faces, procedure: dict, sensor: dict = MPU9150) -> dict:
    """A session manifest (``SessionWriter.create``'s) of one pending static step ``p0``, ``p1``... per face
    (nominal specific force, g, sensor frame), for ``procedure`` (``name``, ``text``...) and ``sensor``."""
    return {"procedure": procedure, "software": {"name": "rig", "version": "test"}, "rig": {"sensor": dict(sensor)},
            "steps": [{"index": i, "name": f"p{i}", "kind": "static", "angles_deg": None, "f_nominal": f,
                       "status": "pending"} for i, f in enumerate(faces)]}
