"""Session -> :class:`calib.file.apply.Recording`: what ``rig apply`` hands to :meth:`CalibrationFile.apply`.

Every sample of the session, as recorded: the raw counts of each sensor (the counts-equivalent of an
imported recording in physical units, docs/import.md), time from the session's start, the temperature
when the sensor has a thermometer, and what the refusals compare: the sensor model and the sensitivities
of the ranges recorded (``rig.sensor`` of session.yaml).
"""

from __future__ import annotations

from calib.file.apply import Recording
from rig.session import MAG_COUNTS_PER_UT, Session


def recording_from_session(session: Session) -> Recording:
    """The session's samples and sensor as a :class:`Recording` labelled ``session PATH``."""
    d = session.samples
    sensor = session.info.rig.sensor
    mag = sensor.magnetometer
    return Recording(
        sensor_model=sensor.model, label=f"session {session.path}", t_s=d["t_s"],
        temp_c=d["temp_c"] if session.has_temperature else None,
        accel=d["accel_counts"], accel_unit="counts", lsb_per_g=sensor.accel_lsb_per_g,
        accel_range_g=sensor.accel_range_g,
        gyro=d.get("gyro_counts"), gyro_unit="counts", lsb_per_dps=sensor.gyro_lsb_per_dps,
        gyro_range_dps=sensor.gyro_range_dps,
        mag=d.get("mag_counts"), mag_unit="counts",
        mag_lsb_per_ut=(mag.mag_lsb_per_ut if mag is not None else None) or MAG_COUNTS_PER_UT)
