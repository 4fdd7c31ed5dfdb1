"""A fixture's bus budget at the rate a run reads its slots (issue 30, "Bus budget" in docs/fixture.md).

The rig file's own check is at its ``fixture.rate_hz`` (100 Hz in ``rigs/sim-fixture.yaml``); a run reads every slot
at its procedure's ``sample_rate_hz`` (``six_position_rapid.yaml``: 200 Hz, where 8 MPU-9150 behind one TCA9548A
need 62 % of a 400 kHz bus, 6 fit in the 50 % a fixture may plan). The simulated bus has no wire time, so nothing
but this check refuses there what the hardware could not carry: a batch, a re-test (judged on the slots it runs) and
a resume (on the slots it resumes) are refused before anything moves, in one line with the numbers, exit 2.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rig.cli import main
from rig.config.procedure import load_procedure
from rig.config.rigfile import load_rig_file
from rig.devices import open_rig_file
from rig.errors import RigInputError
from rig.execution.context import RunAborted
from rig.execution.fixture import check_fixture_bus
from rig.workflow.batch import run_batch
from rig.workflow.lifecycle import NewSession

from conftest import PROCEDURES, RIGS
from fixture_runs import CtrlCAt, fixture_rig_file

RAPID = PROCEDURES / "six_position_rapid.yaml"
#: the line of the rapid procedure's sensor section (where its sample rate is stated)
RAPID_SENSOR_LINE = next(i for i, line in enumerate(RAPID.read_text().splitlines(), 1) if line.startswith("sensor:"))
EIGHT_AT_200_HZ = ("sensor.sample_rate_hz: bus sim cannot carry its 8 slots at 200 Hz: 249 kbit/s of wire time of "
                   "its 400 kbit/s (62 %; a fixture may plan 50 %): it carries the first 6 at this rate, or at most "
                   "142.857 Hz for these 8 (docs/fixture.md, \"Bus budget\")")


def _tree(d: Path) -> dict:
    return {p.relative_to(d): p.read_bytes() for p in d.rglob("*") if p.is_file() and p.name != "session.lock"}


def test_eight_slots_at_the_rapid_procedures_200_hz_are_refused_before_anything_moves(tmp_path, capsys):
    code = main(["run", str(RAPID), "--rig", str(RIGS / "sim-fixture.yaml"), "--out", str(tmp_path / "out"),
                 "--time-scale", "0"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err == [f"rig run: {RAPID}:{RAPID_SENSOR_LINE}: {EIGHT_AT_200_HZ}"], err
    assert not (tmp_path / "out").exists()


def test_six_slots_pass_the_budget_and_record_the_rapid_procedure_at_200_hz(tmp_path):
    """Six slots are carried: the run is not refused, every slot records its first pose at the procedure's 200 Hz
    (stopped by Ctrl-C at the second pose's capture; a whole rapid batch on a fixture is test_fixture_targeted's)."""
    from rig.session.reader import load_session
    from rig.workflow.run import run_procedure

    with pytest.raises(RunAborted) as stopped:
        run_procedure(str(RAPID), rig_spec=str(fixture_rig_file(tmp_path, 6)), out_dir=tmp_path / "out", seed=3,
                      time_scale=0, ui=CtrlCAt(1), history=str(tmp_path / "h.sqlite"))
    record = json.loads((Path(stopped.value.session_dir) / "batch.json").read_text())
    assert [s["slot"] for s in record["slots"]] == [0, 1, 2, 3, 4, 5]
    for entry in record["slots"]:
        session = load_session(Path(stopped.value.session_dir) / entry["session"])
        (first,) = [s for s in session.steps if s.status == "complete"]
        t_s = session.step_samples(first.index)["t_s"]
        assert abs(1 / float(np.median(np.diff(t_s))) - 200.0) < 1.0


def test_a_retest_is_judged_on_the_slots_it_runs(tmp_path, capsys):
    code = main(["run", str(RAPID), "--rig", str(RIGS / "sim-fixture.yaml"), "--out", str(tmp_path / "out"),
                 "--time-scale", "0", "--slots", "0,1,2,3,4,5,7"])
    err = capsys.readouterr().err
    assert code == 2 and not (tmp_path / "out").exists()
    assert ("sensor.sample_rate_hz: bus sim cannot carry the 7 slots of this re-test at 200 Hz: 217 kbit/s of wire "
            "time of its 400 kbit/s (54 %") in err, err
    fixture = load_rig_file(RIGS / "sim-fixture.yaml").fixture
    check_fixture_bus(load_procedure(RAPID), fixture, [1, 2, 3, 5, 6, 7])  # six of the eight: the bus carries them
    with pytest.raises(RigInputError, match="cannot carry its 8 slots at 200 Hz"):
        check_fixture_bus(load_procedure(RAPID), fixture)


def test_a_batch_recorded_beyond_the_budget_is_not_resumed(tmp_path, capsys):
    """A batch of 8 slots at 200 Hz recorded without the check (as before it existed), stopped at its 2nd pose: its
    resume reads the 8 slots at the rate the sessions recorded, and is refused before anything is touched."""
    procedure_path = tmp_path / "p.yaml"
    procedure_path.write_text("format: rig-procedure/1\nname: p\nsensor: {accel_range_g: 4, sample_rate_hz: 200}\n"
                              "dwell: {seconds: 1}\nsteps:\n  - pose: \"+Z up\"\n  - pose: \"-Z up\"\n")
    rig_path = fixture_rig_file(tmp_path, 8)
    procedure = load_procedure(procedure_path)
    rig = open_rig_file(load_rig_file(rig_path), seed=3, time_scale=0)
    new = NewSession(tmp_path / "out", "old-batch", procedure_path.read_text(), str(procedure_path),
                     extra={"seed": 3})
    try:
        with pytest.raises(RunAborted):
            run_batch(procedure, rig, new, CtrlCAt(1), solve=False)
    finally:
        rig.close()
    batch = tmp_path / "out" / "old-batch"
    before = _tree(batch)
    assert main(["run", "--resume", str(batch), "--time-scale", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"rig run: {procedure_path}:3: sensor.sample_rate_hz: bus sim cannot carry the 8 slots this resume "
                   "reads at 200 Hz: 249 kbit/s of wire time of its 400 kbit/s (62 %; a fixture may plan 50 %): it "
                   "carries the first 6 at this rate, or at most 142.857 Hz for these 8 (docs/fixture.md, "
                   "\"Bus budget\")"], err
    assert _tree(batch) == before
