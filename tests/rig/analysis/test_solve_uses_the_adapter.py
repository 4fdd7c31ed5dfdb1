"""``calibrate_session`` is calib's solver on the adapter's step means, with the typed manifest's sensor."""

from __future__ import annotations

import numpy as np

import calib
from rig.analysis.solve import calibrate_session
from rig.session import SessionWriter, load_session, step_means

from written_sessions import faces_manifest


def test_calibrate_session_is_calib_solve_of_the_adapters_step_means(tmp_path):
    faces = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
    manifest = faces_manifest(faces, {"name": "six", "text": "solve: {model: triangular, method: pinv, thermal: off}\n"},
                              {"model": "ADXL345", "address": 83, "serial": "A1", "accel_lsb_per_g": 256.0,
                               "sample_rate_hz": 100.0, "has_temperature": False})
    w = SessionWriter.create(tmp_path, "six", manifest)
    rng = np.random.default_rng(2)
    for i, f in enumerate(faces):
        a = np.round(np.array(f) * 260 + [3, -2, 5] + rng.normal(0, 2, (200, 3))).astype(int)
        w.append_samples(i, i * 10 + np.arange(200) * 0.01, a)
        w.complete_step(i, {"n_samples": 200})
    w.set_status("complete")
    cal = calibrate_session(tmp_path / "six")
    expected = calib.solve(step_means(load_session(tmp_path / "six")), model="triangular", method="pinv",
                           thermal="off")
    np.testing.assert_array_equal(cal.accelerometer.bias_counts, expected.bias_counts)
    assert cal.sensor == {"model": "ADXL345", "address": 83, "serial": "A1"}
