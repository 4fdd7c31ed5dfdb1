"""Discovery on recordings whose poses are unknown and never repeat (hand-held, imu_tk style): the
magnitude model |M^-1 (a - b)| = 1 g is the baseline, and only each step's residual along its gravity
direction is evidence. Clean sessions name nothing; a hidden bias drift or jump is named and
recovered; the report never invents poses or a calibration."""

from __future__ import annotations

import numpy as np
import pytest

from calib.accel.inputs import StepMeans
from calib.discovery.search import StepContext, discover
from calib.errors import CalibError
from calib.synthetic import triangular_matrix

LSB = 8192.0
M = triangular_matrix([8150.0, 8230.0, 8190.0], 0.004, -0.003, 0.002)
BIAS = np.array([120.0, -75.0, 210.0])


def _hand_held(k=40, seed=0, drift_counts_per_s=None, jump_counts=None, sem_counts=2.0):
    """Random orientations (no two alike), unknown to the solver; one step every 15 s."""
    rng = np.random.default_rng(seed)
    f = rng.normal(size=(k, 3))
    f /= np.linalg.norm(f, axis=1)[:, None]
    t = np.arange(k) * 15.0
    a = f @ M.T + BIAS
    if drift_counts_per_s is not None:
        a += np.outer(t - t.mean(), drift_counts_per_s)
    if jump_counts is not None:
        a += np.outer(t >= t[k // 2] - 1.0, jump_counts)
    a += rng.normal(0.0, sem_counts, a.shape)
    return StepMeans(names=tuple(f"static {i + 1}" for i in range(k)), f_nominal_g=np.full((k, 3), np.nan),
                     mean_counts=a, sem_counts=np.full((k, 3), sem_counts), n_samples=np.full(k, 300),
                     temp_c=None, t_s=t, lsb_per_g=LSB)


def _discover(steps):
    """Each step its own unknown pose, as ``rig discover`` labels an imported hand-held recording."""
    return discover(steps, StepContext(pose_group=np.arange(len(steps))))


@pytest.mark.parametrize("seed", range(8))
def test_a_clean_hand_held_session_names_nothing_and_the_gap_is_closed(seed):
    d = _discover(_hand_held(seed=seed))
    assert d.baseline == "magnitude"
    assert d.effects == [] and d.gap_closed, ([e.name for e in d.effects], d.chi2_per_dof_after)
    assert 0.4 < d.chi2_per_dof_before < 2.0
    assert d.calibration is None  # directions were estimated, not known: no calibration from discover


def test_a_hidden_bias_drift_is_named_and_recovered_within_3_sigma():
    drift = np.array([0.08, -0.05, 0.06])  # counts/s: ~10 mg... over 10 minutes, 36 ug/min
    d = _discover(_hand_held(seed=3, drift_counts_per_s=drift))
    names = [e.name for e in d.effects]
    assert names == ["bias_drift"], names
    e = d.effects[0]
    est_counts_per_s = np.array(e.estimate) * LSB  # g/s -> counts/s
    assert np.all(np.abs(est_counts_per_s - drift) < 3 * np.array(e.sigma) * LSB), (est_counts_per_s, e.sigma)
    assert d.gap_closed and d.chi2_per_dof_before > 3 * d.chi2_per_dof_after


def test_a_hidden_bias_jump_is_named_at_the_right_time():
    d = _discover(_hand_held(seed=5, jump_counts=np.array([25.0, -30.0, 20.0])))
    assert [e.name for e in d.effects] == ["bias_jump"]
    assert d.gap_closed


def test_too_few_hand_held_steps_are_refused_with_a_reason():
    with pytest.raises(CalibError, match="cannot determine the baseline"):
        _discover(_hand_held(k=8))
