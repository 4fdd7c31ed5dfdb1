"""`rig discover` on a turntable with its own errors (issue 29 with issue 27: never name what the data do not support).

A simulated table with ``sim.geometry`` on (stage angular errors, lost motion, wobble, non-orthogonalities, the
sensor's mounting, drawn from the rig file's classes) puts every pose a few hundredths of a degree off; on tumble26
that is several times the step noise. Judged against the noise alone, the search took those pose errors for effects
of the sensor: a clean session was told ``full_misalignment``, ``cross_axis_nonlinearity`` and
``scale_nonlinearity`` with the gap not closed. The search now judges the residuals against the noise and the
rig's errors at its rig file's classes (:func:`rig.analysis.discover.rig_covariance`), as the solve's
``misfit_with_rig`` does, and names only what the sensor has, while a hidden effect is still found.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml

from calib.discovery.search import discover
from rig.analysis.discover import discover_session, rig_covariance, step_context
from rig.session import load_session, step_means

from cli_run import rig_in_process as _rig
from conftest import PROCEDURES, RIGS

SEED = 5


def _session(tmp: Path, name: str, effects: dict | None = None) -> Path:
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"].update(time_scale=0, noise="dlpf", geometry={"enabled": True})
    if effects:
        doc["sim"]["effects"] = effects
    rig = tmp / f"{name}.yaml"
    rig.write_text(yaml.safe_dump(doc))
    code, _, err = _rig("run", PROCEDURES / "tumble26.yaml", "--rig", rig, "--out", tmp / name, "--seed", SEED,
                        "--quiet")
    assert code == 0, err
    return next((tmp / name).iterdir())


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("imperfect-table")
    return {"clean": _session(tmp, "clean"), "scale_tempco": _session(tmp, "tempco", {"scale_tempco": 2e-4})}


def test_a_clean_session_on_the_imperfect_table_names_only_what_the_sensor_has(sessions):
    _, found = discover_session(sessions["clean"])
    assert [e.name for e in found.effects] == ["bias_tempco"] and found.gap_closed


def test_judged_against_the_noise_alone_the_tables_errors_were_named(sessions):
    session = load_session(sessions["clean"])
    idx = session.static_step_indices()
    steps = step_means(session, idx)
    cov = rig_covariance(session, steps, idx)
    assert cov is not None and cov.shape == (3 * len(idx), 3 * len(idx))
    noise_only = discover(steps, dataclasses.replace(step_context(session, idx), rig_cov_counts2=None))
    assert len(noise_only.effects) > 1 and not noise_only.gap_closed  # the table's errors, named as the sensor's


def test_a_hidden_effect_is_still_named_on_the_imperfect_table(sessions):
    _, found = discover_session(sessions["scale_tempco"])
    named = {e.name: e for e in found.effects}
    assert set(named) == {"bias_tempco", "scale_tempco"} and found.gap_closed
    est, sig = np.asarray(named["scale_tempco"].estimate), np.asarray(named["scale_tempco"].sigma)
    assert np.all(np.abs(est - 2e-4) < 4 * sig), (est, sig)


def test_a_table_without_errors_adds_nothing(tmp_path):
    """sim.geometry off (today's default): no rig covariance, the search as before."""
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"].update(time_scale=0, geometry={"enabled": False})
    rig = tmp_path / "perfect.yaml"
    rig.write_text(yaml.safe_dump(doc))
    code, _, err = _rig("run", PROCEDURES / "six_position.yaml", "--rig", rig, "--out", tmp_path / "s", "--seed", 3,
                        "--quiet")
    assert code == 0, err
    session = load_session(next((tmp_path / "s").iterdir()))
    assert rig_covariance(session, step_means(session), session.static_step_indices()) is None
