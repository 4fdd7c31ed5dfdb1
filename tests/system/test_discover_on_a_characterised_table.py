"""`rig discover` on a turntable characterised by reversal (issue 27 with issue 29: the rig's own errors, judged at
what is known of them).

A simulated table with its own errors puts every pose a few hundredths of a degree off. At its rig file's classes
those errors hide what they resemble: a sensor mounting rotation (``full_misalignment``) of 0.1 deg is well inside
what the classes allow (its smallest detectable magnitude on tumble26 is about 4.7 mrad, 0.27 deg). Characterising
the rig by reversal (``procedures/characterize_reversal.yaml``, ``rig characterize-rig``) estimates the table's
errors to a few thousandths of a degree; the budget then corrects the poses and judges them at those smaller
uncertainties (:func:`rig.analysis.uncertainty.session_rig_errors`, ``with_budget``), and so does ``rig discover``
(:func:`rig.analysis.discover.judged_with_rig`): the same rotation is then named, and estimated.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml

from calib.accel.rig_misfit import rig_step_covariance
from calib.accel.rig_propagation import needs_arrival
from calib.discovery.search import discover
from rig.analysis.discover import discover_session, judged_with_rig, step_context
from rig.analysis.uncertainty import rig_errors, session_rig_errors, session_rig_facts
from rig.session import load_session, step_means
from rig.session.adapter import with_arrival

from cli_run import rig_in_process as _rig
from conftest import PROCEDURES, RIGS

MOUNTING_TURN_DEG = 0.1  # the sensor turned in its fixture about its x axis: full_misalignment zy = sin(0.1 deg)


def _run(procedure: Path, rig_file: Path, out: Path, seed: int) -> Path:
    code, _, err = _rig("run", procedure, "--rig", rig_file, "--seed", seed, "--yes", "--quiet", "--out", out)
    assert code == 0, err
    (session,) = [p for p in out.iterdir() if p.is_dir()]
    return session


@pytest.fixture(scope="module")
def session(tmp_path_factory) -> Path:
    """A tumble26 session on a simulated table with its errors on, characterised by reversal before it, of a sensor
    turned 0.1 deg in its fixture (the reversal fits the sensor's full matrix, so the turn does not disturb the
    table's characterisation)."""
    tmp = tmp_path_factory.mktemp("characterised-table")
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"].update(time_scale=0, noise="dlpf", geometry={"enabled": True},
                      effects={"full_misalignment": MOUNTING_TURN_DEG})
    rig_file = tmp / "lab.yaml"
    rig_file.write_text(yaml.safe_dump(doc, sort_keys=False))
    reversal = _run(PROCEDURES / "characterize_reversal.yaml", rig_file, tmp / "reversal", 3)
    code, _, err = _rig("characterize-rig", reversal)
    assert code == 0, err
    assert (tmp / "lab.characterisation.yaml").exists()
    return _run(PROCEDURES / "tumble26.yaml", rig_file, tmp / "tumble26", 6)


def _class_level(session_dir: Path):
    """The session's step means, context and covariance as discovery judged them before it read characterisations:
    nominal poses, the rig file's classes."""
    s = load_session(session_dir)
    idx = s.static_step_indices()
    steps = step_means(s, idx)
    rig = rig_errors(session_rig_facts(s))
    judged = with_arrival(s, steps, idx) if needs_arrival(rig) else steps
    return s, idx, steps, rig_step_covariance(judged, rig, steps.lsb_per_g * np.eye(3))


def test_the_characterised_rig_is_judged_at_its_characterisation_about_the_poses_it_corrects(session):
    s, idx, steps, class_cov = _class_level(session)
    rig = session_rig_errors(s)
    assert "characterised by reversal" in rig.source  # the budget's rule: this record applies to this session
    corrected, cov = judged_with_rig(s, steps, idx)
    expected = rig.record.characterisation.corrected(steps, rig)
    np.testing.assert_allclose(corrected.f_nominal_g, expected.f_nominal_g)
    assert 1e-4 < np.max(np.abs(np.asarray(corrected.f_nominal_g) - np.asarray(steps.f_nominal_g))) < 1e-2
    judged = with_arrival(s, expected, idx) if needs_arrival(rig) else expected
    np.testing.assert_allclose(cov, rig_step_covariance(judged, rig, steps.lsb_per_g * np.eye(3)))
    assert np.trace(cov) < 0.1 * np.trace(class_cov)  # a few thousandths of a degree in place of the classes


def test_a_mounting_rotation_the_classes_hide_is_named_on_the_characterised_rig(session):
    s, idx, steps, class_cov = _class_level(session)
    at_classes = discover(steps, dataclasses.replace(step_context(s, idx), rig_cov_counts2=class_cov))
    assert "full_misalignment" not in [e.name for e in at_classes.effects]  # inside what the classes allow

    _, found = discover_session(session)
    named = {e.name: e for e in found.effects}
    assert "full_misalignment" in named and found.gap_closed
    fm = named["full_misalignment"]
    zy = fm.axes.index("zy")
    assert abs(fm.estimate[zy] - np.sin(np.radians(MOUNTING_TURN_DEG))) < 4 * fm.sigma[zy], (fm.estimate, fm.sigma)
