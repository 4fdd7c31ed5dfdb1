"""A magnetometer turned without rests is fitted on its samples (issue 32 item 3): each reading a point on the
field ellipsoid with the chip's own noise, measured from the recording; block means of a turning sensor are
chords inside the ellipsoid and give a wrong fit."""

from __future__ import annotations

import numpy as np
import pytest

from calib.errors import CalibError, ObservabilityError
from calib.mag.continuous import sample_noise_ut, solve_mag_ellipsoid_samples
from calib.mag.ellipsoid import fit_ellipsoid
from mag_turning import FIELD_UT, turning_recording, upper_representative

_IU = np.triu_indices(3)


def _z(cal, rec) -> np.ndarray:
    """(fit - truth) / sigma of the hard iron (3) and the upper-triangular matrix (6)."""
    sig = cal.sigma
    zb = (cal.hard_iron_ut - rec["b"]) / np.array([sig[f"hard_iron_{c}"] for c in "xyz"])
    sm = np.array([[sig[f"a_{r}{c}"] for c in "xyz"] for r in "xyz"])
    zm = (cal.matrix - upper_representative(rec["a"]))[_IU] / sm[_IU]
    return np.concatenate([zb, zm])


def test_every_parameter_lands_within_3_sigma_and_the_sigmas_are_the_scatter():
    z = np.array([_z(solve_mag_ellipsoid_samples(rec["m_ut"], FIELD_UT), rec)
                  for rec in (turning_recording(seed, seconds=40.0) for seed in range(8))])
    assert np.abs(z).max() < 3.5, np.abs(z).max()
    assert 0.7 < z.std() < 1.3, z.std()  # 72 values: the sigmas are the errors' scatter, not a bound


def test_the_noise_is_measured_from_consecutive_samples_of_the_turning_sensor():
    for noise in (0.1, 0.4, 1.5):
        rec = turning_recording(1, seconds=20.0, noise_ut=noise)
        assert sample_noise_ut(rec["m_ut"]) == pytest.approx([noise] * 3, rel=0.06)


def test_block_means_of_a_turning_sensor_give_a_wrong_fit_that_the_samples_do_not():
    rec = turning_recording(2, seconds=60.0)
    on_samples = solve_mag_ellipsoid_samples(rec["m_ut"], FIELD_UT)
    assert np.abs(_z(on_samples, rec)).max() < 3
    blocks = rec["m_ut"].reshape(-1, 100, 3)  # the 1 s "static" blocks a user would invent
    sem = blocks.std(axis=1, ddof=1) / np.sqrt(100)
    on_blocks = fit_ellipsoid(blocks.mean(axis=1), sem, FIELD_UT)
    wrong = np.abs(np.diag(on_blocks.matrix) - np.diag(upper_representative(rec["a"])))
    sigma = np.array([on_samples.sigma[f"a_{c}{c}"] for c in "xyz"])
    assert np.all(wrong > 5 * sigma), wrong / sigma  # the blocks' means lie inside the ellipsoid


def test_a_turn_about_one_axis_only_and_too_few_samples_are_refused_with_the_reason():
    planar = turning_recording(3, seconds=20.0, planar=True, noise_ut=0.01)
    with pytest.raises(ObservabilityError, match="plane .* turn it through all three axes"):
        solve_mag_ellipsoid_samples(planar["m_ut"], FIELD_UT)
    with pytest.raises(CalibError, match="at least 100 samples, got 50"):
        solve_mag_ellipsoid_samples(turning_recording(4, seconds=0.5)["m_ut"], FIELD_UT)
    with pytest.raises(CalibError, match="finite"):
        bad = turning_recording(4, seconds=2.0)["m_ut"]
        bad[5, 1] = np.nan
        solve_mag_ellipsoid_samples(bad, FIELD_UT)
