"""The budget of a session recorded on a simulated rig with its geometry errors on (issue 29 items 1, 4, 5):
the rig's Type B inputs come from the session's rig file (stated gravity, approach, the table's classes),
and the simulator's hidden sensor lies within the expanded uncertainty where the Type A sigma misses it."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from calib.numerics.gravity import from_site
from rig.analysis.solve import solve_accelerometer
from rig.analysis.uncertainty import rig_errors, session_rig_file, with_budget
from rig.cli import main
from rig.config.rigfile import parse_rig_file
from rig.session import load_session

from conftest import PROCEDURES

SITE = from_site(52.0, 100.0)
RIG = f"""format: rig-file/1
kind: sim
gravity: {{latitude_deg: 52.0, height_m: 100}}
turntable:
  axes:
    a1: {{approach: positive, slip_ring: true}}
    a2: {{approach: positive, slip_ring: true}}
    a3: {{approach: positive, slip_ring: true}}
sensor: {{model: MPU-9150}}
sim:
  time_scale: 0
  noise: white
  geometry: {{enabled: true, mounting_deg: 0.2, gravity_m_s2: {SITE.g_m_s2!r}}}
"""


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("budget")
    rig = tmp / "rig.yaml"
    rig.write_text(RIG)
    assert main(["run", str(PROCEDURES / "six_position.yaml"), "--rig", str(rig), "--out", str(tmp / "s"),
                 "--seed", "11", "--quiet"]) == 0
    (path,) = (tmp / "s").iterdir()
    return load_session(path)


def test_the_rig_errors_are_the_session_rig_files(session):
    rig = rig_errors(session_rig_file(session))
    assert rig.gravity == SITE and rig.one_direction
    assert rig.table.mounting_deg == 0.2 and rig.table.lost_motion_deg == 0.02


def test_the_hidden_sensor_lies_within_u_where_sigma_misses_it(session):
    accel, steps, model, method = solve_accelerometer(session)
    cal = with_budget(accel, steps, model, method, rig_errors(session_rig_file(session)))
    truth = yaml.safe_load((session.path / "sim_truth.yaml").read_text())["accelerometer"]
    m = np.asarray(truth["matrix"]) * cal.lsb_per_g
    t = np.linalg.inv(np.linalg.inv(np.diag(np.diag(m))) @ m)
    true_angles = {"alpha_yz": -t[0, 1], "alpha_zy": t[0, 2], "alpha_zx": -t[1, 2]}
    u = cal.uncertainty
    err = {n: abs(cal.misalignment[n] - v) for n, v in true_angles.items()}
    assert all(err[n] <= u["misalignment"][n] for n in err)
    assert any(err[n] > 3 * cal.sigma["misalignment"][n] for n in err)  # the Type A sigma alone misses it
    assert np.all(np.abs(np.diag(np.asarray(cal.matrix_counts_per_g)) - np.diag(m)) <= u["scale_counts_per_g"])
    assert np.all(np.abs(np.asarray(cal.bias_counts) - np.asarray(truth["bias_g"]) * cal.lsb_per_g)
                  <= u["bias_counts"])


def test_a_simulated_table_without_its_errors_adds_none_to_the_budget(tmp_path):
    rig = parse_rig_file(RIG.replace("geometry: {enabled: true, mounting_deg: 0.2", "geometry: {enabled: false, "
                                     "mounting_deg: 0.2"), str(tmp_path / "r.yaml"))
    table = rig_errors(rig).table
    assert table.mounting_deg == 0 and table.lost_motion_deg == 0 and table.non_orthogonality_deg == 0
