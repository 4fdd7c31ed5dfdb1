"""The gyroscope and the magnetometer of the digital twin (issue 27 item 4; docs/twin.md).

The accelerometer of a twin is the discovery's model (:mod:`rig.analysis.twin`). The gyroscope and the
magnetometer are the session's own calibration (``calibration.yaml`` in the session folder, written by
the run's solve or by ``rig solve``), turned into the simulator's error-model fields
(``drivers.sensors.sim.error_model``: ``GyroErrorModel``, ``MagErrorModel``):

- gyroscope ``w_counts = M w + b + G f``: ``matrix = M / lsb_per_dps``, ``bias_dps = b / lsb_per_dps``,
  ``g_sensitivity_dps_per_g = G / lsb_per_dps`` (the columns the rate steps determined; the others 0);
- magnetometer ``m = A h + B``: ``soft_iron = A``, ``hard_iron_ut = B`` (the simulator's own convention;
  an ellipsoid fit's ``A`` is known only up to a rotation: said in the notes).

Their noise stays the chip's (not fitted). A sensor without a calibration section is drawn from the
run's seed, as before, and the notes say so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calib.errors import CalibError
from calib.file import calibration as calfile
from rig.session import Session

#: the session's own calibration file
SESSION_CALIBRATION = "calibration.yaml"


def other_sensors(session: Session) -> tuple[dict, dict, list]:
    """(``gyro_errors``, ``mag_errors``, notes) of the twin from the session's calibration file; empty
    mappings for a sensor the file does not calibrate."""
    path = Path(session.path) / SESSION_CALIBRATION
    if not path.is_file():
        return {}, {}, [f"the session has no {SESSION_CALIBRATION}: the gyroscope and magnetometer are drawn from "
                        "the run's seed (rig solve the session first to twin them)"]
    try:
        cal = calfile.read(path)
    except (CalibError, OSError, ValueError) as e:
        return {}, {}, [f"{SESSION_CALIBRATION} could not be read ({e}): the gyroscope and magnetometer are drawn "
                        "from the run's seed"]
    gyro, mag, notes = {}, {}, []
    if cal.gyroscope is not None:
        g, lsb = cal.gyroscope, float(cal.gyroscope.lsb_per_dps)
        gyro = {"matrix": (np.asarray(g.matrix_counts_per_dps, float) / lsb).tolist(),
                "bias_dps": (np.asarray(g.bias_counts, float) / lsb).tolist(),
                "g_sensitivity_dps_per_g": (g.g_matrix() / lsb).tolist()}
    else:
        notes.append("the session's calibration has no gyroscope: it is drawn from the run's seed")
    if cal.magnetometer is not None:
        m = cal.magnetometer
        mag = {"soft_iron": np.asarray(m.matrix, float).tolist(), "hard_iron_ut": np.asarray(m.hard_iron_ut, float).tolist()}
        if m.method == "ellipsoid":
            notes.append("the magnetometer's soft iron is an ellipsoid fit's, known only up to a rotation")
    else:
        notes.append("the session's calibration has no magnetometer: it is drawn from the run's seed")
    return gyro, mag, notes
