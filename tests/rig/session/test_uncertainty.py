"""Per-step standard errors on correlated noise (issue 14, item 7): the adapter's sems against the
true scatter of step means, chi2/dof of clean six-position solves, and the white-noise limit."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))

import calib
from bench_uncertainty import simulate
from calib.synthetic import six_faces
from drivers.sensors.sim.error_model import AccelErrorModel
from rig.session import adapter

ERR = AccelErrorModel.draw(np.random.default_rng(14), "MPU-9150")


def _sessions(n, rate=1000.0, bw=44.0):
    return [adapter.step_means(simulate(ERR, six_faces(), rate, bw, 500 + k)) for k in range(n)]


def _old_sem(session):
    a = session.samples["accel_counts"].astype(float)
    st = session.samples["step"]
    return np.array([np.maximum(a[st == i].std(axis=0, ddof=1), 1 / np.sqrt(12)) / np.sqrt(np.sum(st == i))
                     for i in range(6)])


@pytest.fixture(scope="module")
def dlpf_1k():
    return _sessions(80)


def test_sem_matches_true_scatter_of_step_means_on_dlpf_noise(dlpf_1k):
    """1 kHz / 44 Hz: the scatter of the step means over 80 sessions (480 per axis), each session's
    common offset removed (bias wander slower than the session is a bias the session cannot see;
    factor 6/5 for the removed mean), against the reported sems; the old s/sqrt(n) is ~2.7x too small."""
    exact = adapter.step_means(simulate(ERR, six_faces(), 1000.0, 44.0, 0, noise=False)).mean_counts
    dev = np.array([s.mean_counts - exact for s in dlpf_1k])  # (S, 6, 3)
    dev = dev - dev.mean(axis=1, keepdims=True)
    true = np.sqrt(np.mean(dev**2, axis=(0, 1)) * 6 / 5)
    sem = np.sqrt(np.mean(np.array([s.sem_counts for s in dlpf_1k]) ** 2, axis=(0, 1)))
    ratio = true / sem
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio
    old = np.sqrt(np.mean(_old_sem(simulate(ERR, six_faces(), 1000.0, 44.0, 501)) ** 2, axis=0))
    assert np.all(true / old > 2.0), true / old  # the old formula fails this test


def test_chi2_per_dof_of_clean_six_position_solves_near_one(dlpf_1k):
    chi2 = [calib.solve(s, thermal="off").fit.chi2_per_dof for s in dlpf_1k[:20]]
    assert 0.7 <= np.median(chi2) <= 1.4, np.median(chi2)


def test_white_noise_sem_equals_the_classic_one():
    """White noise (a filter far above the 100 Hz rate: no correlation; no bias wander, whose fast
    flicker components would correlate 100 Hz samples by a few per cent): the VIF is 1 within a few %."""
    for k in range(3):
        sess = simulate(ERR, six_faces(), 100.0, 1e6, 900 + k, wander=False)
        sess.samples["accel_counts"] = sess.samples["accel_counts"]
        new = adapter.step_means(sess).sem_counts
        assert np.allclose(new, _old_sem(sess), rtol=0.04)


def test_sigma_is_the_propagated_one_unless_the_misfit_is_significant():
    """A chi2 that noise explains leaves the sigma alone (no rescaling by a scattering chi2/dof); a
    significant misfit (the model misses something) makes the steps' scatter set the uncertainty."""
    s = _sessions(1)[0]
    nudged = calib.StepMeans(**{**s.__dict__, "mean_counts": s.mean_counts + 0.3 * s.sem_counts * np.array(
        [[1, -1, 1], [-1, 1, -1], [1, 1, -1], [-1, -1, 1], [1, -1, -1], [-1, 1, 1]])})
    bad = calib.StepMeans(**{**s.__dict__, "mean_counts": s.mean_counts + np.array([[30.0, 0, 0]] + [[0, 0, 0]] * 5)})
    c0, c_nudged, c_bad = (calib.solve(x, thermal="off") for x in (s, nudged, bad))
    assert c_nudged.fit.chi2_per_dof != c0.fit.chi2_per_dof
    assert np.allclose(c0.sigma["bias_counts"], c_nudged.sigma["bias_counts"])
    assert c_bad.fit.chi2_per_dof > 10 * max(c0.fit.chi2_per_dof, 0.1)
    assert c_bad.sigma["bias_counts"][0] > 3 * c0.sigma["bias_counts"][0]
