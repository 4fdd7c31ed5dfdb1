"""The gyroscope's uncertainty budget on a turntable (docs/uncertainty.md, "The gyroscope"): the rate test measures
the sensor's axes against the table's rotation axes, so the sensor's mounting in its fixture and the brackets'
non-orthogonality are in its nonorthogonalities, beyond their Type A sigma; U holds them, the contributions add up,
a table without errors leaves U = k sigma, and the section round-trips through the calibration file."""

from __future__ import annotations

import numpy as np
import pytest

from calib.errors import CalibrationFileError
from calib.gyro import GyroCalibration, RateStepMeans, solve_gyro
from calib.gyro.budget import uncertainty_section
from calib.numerics.budget import RigErrors, TableClass
from calib.numerics.turntable import TableGeometry
from drivers.sensors.sim.error_model import GyroErrorModel

from test_calib_gyro_mag import F_G, LSB_PER_DPS, N_GYRO, NOISE_DPS, gyro_named_truth, gyro_truth, seed_rate_modes

#: the sensor turned in its fixture by hundredths of a degree to a tenth (within the mounting class of 0.1 deg)
MOUNTING_DEG = (0.08, -0.06, 0.09)
RIG = RigErrors.from_classes(TableClass())
PERFECT = RigErrors.from_classes(TableClass(**{k: 0.0 for k in ("zero_offset_deg", "periodic_deg", "accumulated_deg",
                                                                "lost_motion_deg", "wobble_deg", "non_orthogonality_deg",
                                                                "mounting_deg")}))


def _mounted_session(seed: int) -> tuple[GyroCalibration, dict]:
    """The seed's 18 rate modes about the table's axes, felt by a sensor turned in its fixture by MOUNTING_DEG:
    (the calibration, the sensor's own parameters by name)."""
    model = GyroErrorModel.draw(np.random.default_rng(seed))
    names, w_table = seed_rate_modes()
    w_sensor = w_table @ TableGeometry(mounting_deg=MOUNTING_DEG).mounting()  # rows: M^T w
    true = LSB_PER_DPS * model.output_dps(w_sensor, np.tile(F_G, (len(w_table), 1)))
    sem = np.full(w_table.shape, NOISE_DPS * LSB_PER_DPS / np.sqrt(N_GYRO))
    rng = np.random.default_rng(seed + 1)
    steps = RateStepMeans(names, w_table, true + rng.normal(size=true.shape) * sem, sem, np.full(len(w_table), N_GYRO),
                          LSB_PER_DPS)
    return solve_gyro(steps), gyro_named_truth(*gyro_truth(model))


def test_the_mounting_is_in_the_nonorthogonalities_beyond_sigma_and_within_u():
    cal, truth = _mounted_session(21)
    u = uncertainty_section(cal, RIG)
    errors = {n: abs(v - truth[n]) for n, v in cal.nonorthogonality.items()}
    assert max(errors[n] / cal.sigma[n] for n in errors) > 20  # the mounting, not the noise
    assert all(errors[n] < u[n] for n in errors), {n: (errors[n], u[n]) for n in errors}


def test_the_contributions_add_up_and_the_biases_and_scales_keep_k_sigma():
    cal, _ = _mounted_session(22)
    u = uncertainty_section(cal, RIG, k=2.0)
    assert [c["name"] for c in u["budget"]] == ["noise and wander", "rig frame (mounting, stage zeros)",
                                                "rig axes (non-orthogonality)"]
    for name, sigma in cal.sigma.items():
        rss = np.sqrt(sum(c[name] ** 2 for c in u["budget"]))
        assert u["combined_standard"][name] == pytest.approx(rss, rel=1e-12)
        assert u[name] == pytest.approx(2.0 * rss, rel=1e-12)
        if not name.startswith("m_"):
            assert u[name] == pytest.approx(2.0 * sigma, rel=1e-12)
    assert u["budget"][1]["m_xy"] == pytest.approx(RIG.table.frame_u_rad())


def test_a_table_without_errors_leaves_k_sigma():
    cal, _ = _mounted_session(23)
    u = uncertainty_section(cal, PERFECT)
    assert all(u[n] == pytest.approx(2.0 * s, rel=1e-12) for n, s in cal.sigma.items())


def test_the_section_round_trips_and_a_bad_coverage_factor_is_refused():
    cal, _ = _mounted_session(24)
    with_u = cal.model_copy(update={"uncertainty": uncertainty_section(cal, RIG)})
    assert GyroCalibration.from_dict(with_u.to_dict()) == with_u
    assert "uncertainty" not in cal.to_dict()  # none made: the file as it was
    bad = with_u.to_dict()
    bad["uncertainty"]["k"] = 0
    with pytest.raises(CalibrationFileError, match=r"uncertainty.k.*coverage factor"):
        GyroCalibration.from_dict(bad)
