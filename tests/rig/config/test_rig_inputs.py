"""Bad input gets one line naming file, line and key, and what is allowed: procedures, rig files, sessions."""

from __future__ import annotations

import numpy as np
import pytest

from rig.errors import RigInputError, SessionFormatError
from rig.planning.kinematics import f_nominal, roll_pitch_deg, sensor_to_world
from rig.planning.targets import move_time_s, plan_axis_target
from rig.planning.poses import CUBE, pose_angles_deg
from rig.config.procedure import load_procedure, load_procedure_text
from rig.config.rigfile import parse_rig_file
from rig.session import SessionWriter, load_session, validate_session_id

from conftest import PROCEDURES, RIGS, unseal

GOOD = """format: rig-procedure/1
name: p
sensor: {accel_range_g: 4, sample_rate_hz: 100}
dwell: {seconds: 2}
steps:
  - pose: "+Z up"
  - pose: "-Z up"
solve: {model: triangular}
"""


def _err(text, path="p.yaml"):
    with pytest.raises(RigInputError) as e:
        load_procedure_text(text, path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(path)
    return msg


def test_every_shipped_procedure_loads():
    for p in PROCEDURES.glob("*.yaml"):
        proc = load_procedure(p)
        assert proc.expanded_steps()


@pytest.mark.parametrize("text,expect", [
    (GOOD.replace("name: p", "name: p\ncolour: red"), "p.yaml:3: colour: unknown key"),
    (GOOD.replace('"+Z up"', '"+W up"'), "p.yaml:6: steps[0] (step 1).pose: unknown pose '+W up'"),
    (GOOD.replace("seconds: 2", "seconds: -1"), "p.yaml:4: dwell.seconds: expected a number > 0"),
    (GOOD.replace("seconds: 2", "seconds: 2, samples: 5"), "dwell: give exactly one of seconds, samples, sem_g"),
    (GOOD.replace("accel_range_g: 4", "accel_range_g: 5"), "p.yaml:3: sensor.accel_range_g: expected one of 2, 4, 8, 16"),
    (GOOD.replace("sample_rate_hz: 100", "sample_rate_hz: 300"), "sensor.sample_rate_hz: the MPU-9150 runs at"),
    (GOOD.replace("model: triangular", "model: cubic"), "solve.model: expected one of triangular, full"),
    (GOOD.replace("rig-procedure/1", "rig-procedure/2"), "p.yaml:1: format: expected 'rig-procedure/1'"),
    (GOOD.replace('  - pose: "-Z up"\n', '  - angles_deg: [0, 90]\n'), "p.yaml:7: steps[1] (step 2).angles_deg: expected [a1, a2, a3]"),
    (GOOD.replace('  - pose: "-Z up"\n', '  - {pose: "+X up", angles_deg: [0, 0, 0]}\n'), "exactly one of pose"),
    (GOOD.replace('  - pose: "-Z up"\n', '  - temperature: {target_c: 200}\n'), "temperature.target_c: expected <= 85"),
    ("steps: [\n", "p.yaml:2: not valid YAML"),
    ("- a\n- b\n", "expected a mapping"),
    (GOOD.replace("name: p", "name: p\nname: q"), "p.yaml:3: name: duplicate key"),
    (GOOD.replace("steps:\n  - pose: \"+Z up\"\n  - pose: \"-Z up\"\n", "steps: []\n"), "steps: expected a non-empty list"),
])
def test_procedure_errors_are_located(text, expect):
    assert expect in _err(text)


def test_yaml_tags_cannot_construct_python_objects():
    msg = _err(GOOD.replace("name: p", "name: !!python/object/apply:os.system ['echo hi']"))
    assert "not valid YAML" in msg


def test_repeat_expands_and_names_steps():
    text = GOOD.replace('  - pose: "-Z up"\n', '  - repeat: 3\n    steps:\n      - pose: "-Z up"\n')
    steps = load_procedure_text(text.replace("solve: {model: triangular}\n", "")).expanded_steps()  # a recording
    assert [s.name for s in steps] == ["+Z up", "r1/-Z up", "r2/-Z up", "r3/-Z up"]
    assert [s.index for s in steps] == [0, 1, 2, 3]


def test_adxl345_procedures_cannot_wait_for_a_thermometer():
    text = GOOD.replace("sensor: {", "sensor: {model: ADXL345, ").replace('  - pose: "-Z up"\n',
                                                                          '  - temperature: {target_c: 30}\n')
    assert "ADXL345 has none" in _err(text)


RIG = (RIGS / "sim.yaml").read_text()


@pytest.mark.parametrize("edit,expect", [
    (lambda t: t.replace("speed_deg_s: 20,", "speed_deg_s: 60,", 1), "r.yaml:10: turntable.axes.a1.speed_deg_s: expected at most 48"),
    (lambda t: t.replace("sign: 1,", "sign: 2,", 1), "turntable.axes.a1.sign: expected 1 or -1"),
    (lambda t: t.replace("soft_limits_deg: [-400, 400]", "soft_limits_deg: [400, -400]", 1), "soft_limits_deg: expected [low, high]"),
    (lambda t: t.replace("address: 0x68", "address: 0x53"), "sensor.address: expected one of 0x68, 0x69"),
    (lambda t: t.replace("kind: sim", "kind: hardware"), "turntable.axes.a1.port: expected the controller's serial port"),
    (lambda t: t + "faults:\n  ximc:\n    a1: {explode: 1}\n", "faults.ximc.a1.explode: unknown key"),
    (lambda t: t + "faults:\n  sensor: {melt_after_s: 3}\n", "faults.sensor.melt_after_s: unknown key"),
    (lambda t: t.replace("    a3:", "    a4:"), "turntable.axes.a4: unknown key"),
])
def test_rig_file_errors_are_located(edit, expect):
    with pytest.raises(RigInputError) as e:
        parse_rig_file(edit(RIG), "r.yaml")
    assert expect in str(e.value)


def test_sim_section_is_validated_against_the_simulator(tmp_path, capsys):
    from rig.cli import main
    p = tmp_path / "r.yaml"
    p.write_text(RIG + "  effects: {telekinesis: 1}\n")
    code = main(["run", str(PROCEDURES / "six_position.yaml"), "--rig", str(p), "--out", str(tmp_path / "s")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "sim.effects.telekinesis: unknown key" in err[0]


# -- kinematics and planning ------------------------------------------------------------------------
def test_kinematics_contract():
    a = np.array([37.0, 20.0, -65.0])
    r = sensor_to_world(a)[0]
    np.testing.assert_allclose(r.T @ [0, 0, 1], f_nominal(a), atol=1e-12)
    roll, pitch = roll_pitch_deg(f_nominal(a))
    assert roll[0] == pytest.approx(-65.0) and pitch[0] == pytest.approx(20.0)  # roll = a3, pitch = a2
    for name, d in CUBE.items():
        np.testing.assert_allclose(f_nominal(pose_angles_deg(name, 123.0)), d, atol=1e-12)
    assert len(CUBE) == 26


def test_planning_picks_the_shortest_legal_equivalent_and_respects_limits():
    assert plan_axis_target(350.0, 10.0, (-400, 400), 400) == pytest.approx(370.0)
    assert plan_axis_target(390.0, 90.0, (-400, 400), 400) == pytest.approx(90.0)  # 450 would pass the wrap
    with pytest.raises(RigInputError, match="unreachable"):
        plan_axis_target(0.0, 180.0, (-100, 100), 400)
    assert move_time_s(90, 20, 40) == pytest.approx(5.0)
    assert move_time_s(4, 20, 40) == pytest.approx(2 * np.sqrt(4 / 40))


# -- sessions ----------------------------------------------------------------------------------------
def _session(tmp_path, n_steps=2, rows=5):
    manifest = {"procedure": {"name": "p", "text": GOOD}, "software": {"name": "rig", "version": "0"},
                "rig": {"sensor": {"model": "MPU-9150", "accel_lsb_per_g": 8192.0, "sample_rate_hz": 100.0,
                                   "has_temperature": True}},
                "steps": [{"index": i, "name": f"s{i}", "kind": "static", "angles_deg": [0, 0, 0],
                           "f_nominal": [0.0, 0.0, 1.0], "status": "pending"} for i in range(n_steps)]}
    w = SessionWriter.create(tmp_path, "sess-1", manifest)
    for i in range(n_steps):
        w.append_samples(i, np.arange(rows) * 0.01 + i, np.tile([1, 2, 8192], (rows, 1)), temp_c=np.full(rows, 25.0))
        w.complete_step(i, {"n_samples": rows})
    w.set_status("complete")
    return tmp_path / "sess-1"


def test_session_round_trip(tmp_path):
    d = _session(tmp_path)
    s = load_session(d)
    assert s.info.to_dict()["format"] == "rig-session/1" and len(s.samples["t_s"]) == 10 and not s.warnings
    sm = s.step_means()
    np.testing.assert_allclose(sm.mean_counts, [[1, 2, 8192]] * 2)


def test_torn_last_line_is_dropped_and_said(tmp_path):
    d = unseal(_session(tmp_path))  # a torn line past a seal is refused: this stands for a session without one
    with open(d / "samples.csv", "a") as fh:
        fh.write("0.1,1,5,5")
    s = load_session(d)
    assert len(s.samples["t_s"]) == 10 and "torn last line" in s.warnings[0]


@pytest.mark.parametrize("edit,expect", [
    (lambda d: (d / "samples.csv").write_text((d / "samples.csv").read_text() + "0.5,1,nan,2,3,25,0,0,0\n"), "ax: expected a number"),
    (lambda d: (d / "samples.csv").write_text((d / "samples.csv").read_text() + "0.5,7,1,2,3,25,0,0,0\n"), "index 7 is no step of the manifest"),
    (lambda d: (d / "samples.csv").write_text((d / "samples.csv").read_text() + "0.5,1,1.5,2,3,25,0,0,0\n"), "raw counts must be integers"),
    (lambda d: (d / "samples.csv").write_text((d / "samples.csv").read_text() + "0.5,1,abc,2,3,25,0,0,0\n"), "samples.csv:12"),
    (lambda d: (d / "session.yaml").write_text((d / "session.yaml").read_text().replace("rig-session/1", "rig-session/7")), "format: expected 'rig-session/1'"),
    (lambda d: (d / "session.yaml").write_text((d / "session.yaml").read_text().replace("accel_lsb_per_g: 8192.0", "accel_lsb_per_g: -1")), "rig.sensor.accel_lsb_per_g"),
    (lambda d: (d / "samples.csv").write_text("t_s,step,ax\n"), "ay: missing column"),
])
def test_damaged_sessions_are_refused_with_a_located_line(tmp_path, edit, expect):
    d = _session(tmp_path)
    edit(d)
    with pytest.raises(SessionFormatError) as e:
        load_session(d)
    assert expect in str(e.value) and "\n" not in str(e.value)


def test_extra_columns_in_any_order_are_accepted(tmp_path):
    d = unseal(_session(tmp_path))  # another tool's columns: a session without a seal
    rows = (d / "samples.csv").read_text().splitlines()
    header = rows[0].split(",")
    order = [5, 0, 4, 3, 2, 1, 6, 7, 8]
    out = [",".join([header[i] for i in order] + ["note"])]
    for r in rows[1:]:
        f = r.split(",")
        out.append(",".join([f[i] for i in order] + ["7"]))
    (d / "samples.csv").write_text("\n".join(out) + "\n")
    s = load_session(d)
    np.testing.assert_allclose(s.step_means().mean_counts, [[1, 2, 8192]] * 2)


@pytest.mark.parametrize("bad", ["../evil", "a/b", "..", "", ".hidden", "x" * 200])
def test_session_ids_cannot_escape_the_sessions_directory(tmp_path, bad):
    with pytest.raises(SessionFormatError):
        validate_session_id(bad)


def test_a_tag_inside_a_flow_sequence_is_one_line_with_its_line_number():
    """Found by the fuzzer: an unknown tag on a list item gave a three-line message."""
    from rig.config.rigfile import parse_rig_file
    text = (RIGS / "sim.yaml").read_text().replace("soft_limits_deg: [-400, 400]", "soft_limits_deg: [!-400, 400]", 1)
    with pytest.raises(RigInputError) as exc:
        parse_rig_file(text, "r.yaml")
    assert str(exc.value).startswith("r.yaml:") and "\n" not in str(exc.value) and "tag" in str(exc.value)


def test_a_solve_the_poses_cannot_determine_is_refused_at_load_with_its_line():
    assert "p.yaml:8: solve: the pose set leaves k_x, alpha_yz, k_y undetermined" in _err(GOOD)
    six = GOOD.replace('  - pose: "-Z up"\n', "".join(f'  - pose: "{f}"\n' for f in ("-Z up", "+X up", "-X up", "+Y up",
                                                                                      "-Y up")))
    assert [s.name for s in load_procedure_text(six).expanded_steps()][-1] == "-Y up"
    assert "the pose set leaves m_xy" in _err(six.replace("model: triangular", "model: full")
                                              .replace('  - pose: "+Y up"\n  - pose: "-Y up"\n', ""))


def test_a_flip_solve_without_a_pair_on_every_axis_is_refused_at_load():
    flip = GOOD.replace("solve: {model: triangular}", "solve: {model: triangular, method: flip}")
    assert "the flip method needs poses with gravity along +X and -X; the procedure has 0 and 0" in _err(flip)
