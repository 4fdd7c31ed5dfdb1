"""Rig characterisation by reversal from a recorded session (issue 29 item 3): a procedure's prompts turn the
sensor in its fixture (``mount:``), the simulated operator who confirms them turns the simulated sensor, the
session records each step's mounting, and the steps grouped by mounting give back the simulated turntable's
hidden non-orthogonalities and fixture misalignment within 3 of their stated standard uncertainties."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
import yaml

from calib.errors import CalibError
from drivers.sensors.sim.physics import StaticPhysics
from rig.analysis.rig_characterisation import characterise_session, mounting_groups
from rig.cli import main
from rig.config.procedure import load_procedure, load_procedure_text
from rig.session import load_session
from rig.simulation.mounting import MountedPhysics

from conftest import PROCEDURES, RIGS

Z180 = [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]


def geometry_rig(tmp) -> str:
    """A copy of the simulated rig file with the turntable's own errors on (``sim.geometry``)."""
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"].update(time_scale=0, geometry={"enabled": True})
    path = tmp / "lab.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return str(path)


def record(tmp, procedure, rig_file, seed=3):
    with contextlib.redirect_stdout(io.StringIO()):
        code = main(["run", str(procedure), "--rig", rig_file, "--time-scale", "0", "--seed", str(seed), "--yes",
                     "--quiet", "--out", str(tmp / "s")])
    assert code == 0
    return max((tmp / "s").iterdir(), key=lambda p: p.stat().st_mtime)


@pytest.fixture(scope="module")
def reversal(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("reversal")
    session_dir = record(tmp, PROCEDURES / "characterize_reversal.yaml", geometry_rig(tmp))
    return load_session(session_dir), yaml.safe_load((session_dir / "sim_truth.yaml").read_text())["geometry"]


def hidden(geometry: dict) -> dict:
    """The table errors a reversal estimates, under the names it holds them by (calib.accel.reversal: mounting.x
    holds minus a1_a3, mounting.y a3's zero)."""
    m, no, stages = geometry["mounting_deg"], geometry["non_orthogonality_deg"], geometry["stages"]
    return {"mounting.x": m["x"] - no["a1_a3"], "mounting.y": m["y"] + stages["a3"]["zero_offset_deg"],
            "mounting.z": m["z"], "non_orthogonality.a1_a2": no["a1_a2"], "non_orthogonality.a2_a3": no["a2_a3"],
            # a2's zero: its periodic and accumulated errors at the recorded a2 angles are a zero offset there, in
            # every mounting; the fit's u carries their classes (calib.accel.reversal._aliased)
            "zero_offset.a2": stages["a2"]["zero_offset_deg"] + no["a1_a3"]}


def test_the_hidden_non_orthogonalities_and_mounting_are_recovered_within_3_u(reversal):
    session, geometry = reversal
    fit = characterise_session(session).characterisation
    for name, truth in hidden(geometry).items():
        assert abs(fit.estimate_deg[name] - truth) < 3 * fit.u_deg[name], (name, fit.estimate_deg[name], truth)
        assert fit.u_deg[name] < 0.02 / np.sqrt(3)  # inside the class it replaces
    assert 0.3 < fit.chi2_per_dof < 5


def test_the_session_records_each_steps_mounting_and_what_the_turned_sensor_feels(reversal):
    session, _ = reversal
    groups = mounting_groups(session)
    assert [len(members) for _, members in groups] == [6, 6, 6]
    np.testing.assert_array_equal(groups[1][0], Z180)
    step = session.info.steps[groups[1][1][0]]  # "+X up" of the table with the sensor turned about z: its -x up
    assert step.name == "+X up" and step.f_nominal == [-1.0, 0.0, 0.0]


def test_one_mounting_only_is_refused_with_the_reason(tmp_path):
    text = (PROCEDURES / "characterize_reversal.yaml").read_text()
    one = tmp_path / "one.yaml"
    one.write_text(text[:text.index("  - prompt: Turn the sensor 180 deg about its z")].replace("{seconds: 10}",
                                                                                                  "{seconds: 2}"))
    session = load_session(record(tmp_path, one, geometry_rig(tmp_path)))
    with pytest.raises(CalibError, match="one mounting only: the table's errors and the sensor's are the same"):
        characterise_session(session)


def test_a_session_without_mountings_is_refused_in_one_line(tmp_path):
    six = tmp_path / "six.yaml"
    six.write_text((PROCEDURES / "six_position.yaml").read_text().replace("{seconds: 10}", "{seconds: 2}"))
    session = load_session(record(tmp_path, six, geometry_rig(tmp_path)))
    with pytest.raises(CalibError, match="the session records no mounting") as exc:
        characterise_session(session)
    assert "\n" not in str(exc.value)


def test_a_turn_applies_from_its_instant_on_even_to_samples_read_later():
    physics = MountedPhysics(StaticPhysics(specific_force_g=(0.1, 0.2, 0.97)))
    physics.turn_at(5.0, Z180)
    f = physics(np.array([4.0, 5.0, 6.0])).specific_force_g
    np.testing.assert_allclose(f, [[0.1, 0.2, 0.97], [-0.1, -0.2, 0.97], [-0.1, -0.2, 0.97]])


@pytest.mark.parametrize("mount, message", [
    ("x-z*", "steps[0] (step 1).mount: expected a cube-rotation name such as x+z+"),
    ("{axis: w, deg: 90}", "steps[0] (step 1).mount.axis: expected x, y or z"),
    ("{axs: z, deg: 90}", "unknown key 'axs' (expected axis and deg): did you mean 'axis'?"),
])
def test_a_bad_mount_is_one_line_naming_file_line_and_key(mount, message):
    text = f"format: rig-procedure/1\nname: t\nsteps:\n  - prompt: turn it\n    mount: {mount}\n  - pose: '+Z up'\n"
    with pytest.raises(Exception) as exc:
        load_procedure_text(text, "p.yaml")
    assert str(exc.value).startswith("p.yaml:5: ") and message in str(exc.value) and "\n" not in str(exc.value)


def test_axis_and_degrees_name_the_same_turn_as_the_cube_rotation():
    a = load_procedure_text("format: rig-procedure/1\nname: t\nsteps:\n  - prompt: turn\n    mount: {axis: x, deg: 180}"
                            "\n  - pose: '+Z up'\n")
    assert a.steps[0].mount.name == "x+z-" and a.steps[1].f_nominal == (0.0, 0.0, -1.0)
    assert [s.mount.name for s in load_procedure(PROCEDURES / "characterize_reversal.yaml").steps[::7]] == \
        ["x+z+", "x-z+", "x+z-"]


class _Technician:
    """Confirms every prompt; with ``stop_at`` (a step index) stops the run, as Ctrl-C would, when that step starts."""

    def __init__(self, stop_at: int | None = None) -> None:
        self.stop_at = stop_at
        self.asked: list[str] = []

    def info(self, message: str) -> None:
        pass

    def warn(self, message: str) -> None:
        pass

    def progress(self, progress) -> None:
        if progress.index == self.stop_at:
            from rig.execution.context import RunAborted
            raise RunAborted(f"stopped by the operator at {progress.name}")

    def can_confirm(self) -> bool:
        return True

    def confirm(self, question: str) -> bool:
        self.asked.append(question)
        return True


def test_a_run_resumed_after_a_turn_resumes_in_that_mounting_and_characterises_as_an_unbroken_one(reversal, tmp_path):
    from rig.execution.context import RunAborted
    from rig.workflow.run import run_procedure
    steps = load_procedure(PROCEDURES / "characterize_reversal.yaml").expanded_steps()
    turned = [s for s in steps if s.kind == "static" and s.mount is not None and s.mount.name == "x-z+"]
    stop = turned[3].index  # the fourth face turned about z
    with pytest.raises(RunAborted):
        run_procedure(str(PROCEDURES / "characterize_reversal.yaml"), rig_spec=geometry_rig(tmp_path),
                      out_dir=tmp_path / "s", seed=3, time_scale=0, ui=_Technician(stop_at=stop), solve=False)
    session_dir = next((tmp_path / "s").iterdir())
    resumed = _Technician()
    run_procedure(None, resume_dir=session_dir, ui=resumed, time_scale=0, solve=False)
    # asked first to confirm the sensor is still turned about z, as after the prompt before the stop
    assert resumed.asked[0].startswith(f"The run resumes at step {turned[3].index + 1}") and "about z" in resumed.asked[0]
    fit = characterise_session(load_session(session_dir)).characterisation
    unbroken = characterise_session(reversal[0]).characterisation
    for name in unbroken.estimate_deg:  # the same hidden table and sensor (seed 3): the same table errors
        assert abs(fit.estimate_deg[name] - unbroken.estimate_deg[name]) < 2 * unbroken.u_correction_deg[name], name
    assert fit.chi2_per_dof < 3
