"""The digital twin carries the gyroscope and the magnetometer too (issue 27 item 4; docs/twin.md).

``gyro_rates.yaml`` runs on the simulated rig (virtual time; its solve writes the gyroscope into the
session's calibration.yaml); ``rig discover --twin`` writes the twin, whose ``sim.gyro_errors`` are that
calibration in the simulator's units and agree with the hidden truth within the calibration's 3 sigma; the same for
``mag_eight_position.yaml``'s magnetometer (``sim.mag_errors``).
"""

from __future__ import annotations


import numpy as np
import yaml

from calib.file import calibration as calfile

from conftest import PROCEDURES
from cli_run import rig_in_process as _rig


def test_the_twin_of_a_gyro_session_carries_its_gyroscope_calibration(tmp_path):
    code, _, err = _rig("run", PROCEDURES / "gyro_rates.yaml", "--seed", 3, "--time-scale", 0, "--out",
                        tmp_path / "s", "--quiet", "--yes")
    assert code == 0, err
    session = next((tmp_path / "s").iterdir())
    code, _, err = _rig("discover", session, "--twin", tmp_path / "twin.yaml")
    assert code == 0, err
    twin = yaml.safe_load((tmp_path / "twin.yaml").read_text())
    gyro = twin["sim"]["gyro_errors"]
    cal = calfile.read(session / "calibration.yaml").gyroscope
    lsb = cal.lsb_per_dps
    truth = yaml.safe_load((session / "sim_truth.yaml").read_text())["gyroscope"]
    sigma_dps = np.array([cal.sigma[f"b_{a}"] for a in "xyz"]) / lsb
    assert np.all(np.abs(np.array(gyro["bias_dps"]) - truth["bias_dps"]) < 3 * sigma_dps), (gyro, truth)
    assert np.allclose(gyro["matrix"], truth["matrix"], atol=1e-3)
    assert "mag_errors" not in twin["sim"]  # gyro_rates solves no magnetometer: drawn from the seed, and said
    assert "no magnetometer" in (tmp_path / "twin.yaml").read_text()


def test_the_twin_of_a_magnetometer_session_carries_its_magnetometer_calibration(tmp_path):
    code, _, err = _rig("run", PROCEDURES / "mag_eight_position.yaml", "--seed", 3, "--time-scale", 0, "--out",
                        tmp_path / "s", "--quiet", "--yes")
    assert code == 0, err
    session = next((tmp_path / "s").iterdir())
    code, _, err = _rig("discover", session, "--twin", tmp_path / "twin.yaml")
    assert code == 0, err
    mag = yaml.safe_load((tmp_path / "twin.yaml").read_text())["sim"]["mag_errors"]
    cal = calfile.read(session / "calibration.yaml").magnetometer
    truth = yaml.safe_load((session / "sim_truth.yaml").read_text())["magnetometer"]
    sigma_b = np.array([cal.sigma[f"hard_iron_{a}"] for a in "xyz"])
    sigma_a = np.array([[cal.sigma[f"a_{r}{c}"] for c in "xyz"] for r in "xyz"])
    # the positions method (known poses and site field): the twin's A and B are the hidden ones within 3 sigma
    assert np.all(np.abs(np.array(mag["hard_iron_ut"]) - truth["hard_iron_ut"]) < 3 * sigma_b), (mag, truth)
    assert np.all(np.abs(np.array(mag["soft_iron"]) - np.array(truth["soft_iron"])) < 3 * sigma_a), (mag, truth)
