"""session.yaml as a typed model: validated on load (one line naming the key path), unknown keys kept,
and a writer takes the model or the plain mapping alike."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from rig.errors import SessionFormatError
from rig.session import (ProcedureInfo, RigInfo, SensorInfo, SessionManifest, SessionWriter, StepRecord, load_session,
                         step_means)

SENSOR = {"model": "MPU-9150", "address": 104, "accel_lsb_per_g": 8192.0, "sample_rate_hz": 100.0,
          "has_temperature": True}


def _mapping(n_steps=2):
    return {"procedure": {"name": "p", "file": None, "sha256": None, "text": "solve: {model: full}\n"},
            "software": {"name": "rig", "version": "0"},
            "rig": {"kind": "test", "sensor": dict(SENSOR), "future_key": {"a": 1}},
            "steps": [{"index": i, "name": f"s{i}", "kind": "static", "angles_deg": [0.0, 0.0, 0.0],
                       "f_nominal": [0.0, 0.0, 1.0], "status": "pending"} for i in range(n_steps)]}


def _model(session_id="sess-1", n_steps=2):
    return SessionManifest(id=session_id, created="2024-01-01T00:00:00+00:00",
                           procedure=ProcedureInfo(name="p", file=None, sha256=None, text="solve: {model: full}\n"),
                           software={"name": "rig", "version": "0"},
                           rig=RigInfo(kind="test", sensor=SensorInfo(**SENSOR), future_key={"a": 1}),
                           steps=[StepRecord(index=i, name=f"s{i}", angles_deg=[0, 0, 0], f_nominal=[0, 0, 1])
                                  for i in range(n_steps)])


def _record(tmp_path, manifest, session_id="sess-1"):
    w = SessionWriter.create(tmp_path, session_id, manifest)
    for i in range(2):
        w.append_samples(i, np.arange(5) * 0.01 + i, np.tile([1, 2, 8192], (5, 1)), temp_c=np.full(5, 25.0))
        w.complete_step(i, {"n_samples": 5})
    w.set_status("complete")
    return tmp_path / session_id


def test_a_writer_takes_the_model_or_the_mapping_and_writes_the_same_manifest(tmp_path):
    a = _record(tmp_path / "a", dict(_mapping(), created="2024-01-01T00:00:00+00:00"))
    b = _record(tmp_path / "b", _model())
    ma, mb = (yaml.safe_load((d / "session.yaml").read_text()) for d in (a, b))
    for m in (ma, mb):  # the end time, and the hashes of the events' times (the seal, each step's events link)
        m.pop("ended"), m.pop("seal")
        for step in m["steps"]:
            step["stats"].pop("events_sha256")
    assert ma == mb
    assert (a / "samples.csv").read_bytes() == (b / "samples.csv").read_bytes()


def test_the_loaded_session_exposes_the_typed_manifest_and_writes_it_back_unchanged(tmp_path):
    s = load_session(_record(tmp_path, _model()))
    assert isinstance(s.info, SessionManifest) and s.info.status == "complete"
    assert s.info.rig.sensor.accel_lsb_per_g == 8192.0 and s.info.steps[1].stats.n_samples == 5
    assert s.info.rig.model_extra == {"future_key": {"a": 1}}  # unknown keys are kept
    as_read = yaml.safe_load((s.path / "session.yaml").read_text())
    assert as_read["rig"]["future_key"] == {"a": 1} and as_read["steps"][0]["status"] == "complete"
    assert s.info.to_dict() == as_read  # read, then written again: unchanged
    assert s.solve_spec == {"model": "full"}
    np.testing.assert_allclose(step_means(s).mean_counts, [[1, 2, 8192]] * 2)


@pytest.mark.parametrize("edit,expect", [
    (lambda m: m["steps"][1].update(status="done"),
     "steps[1].status: expected one of pending, complete, failed, flagged, got 'done'"),
    (lambda m: m["steps"][1].update(index=3), "steps[1]: expected a step mapping with index 1, got index 3"),
    (lambda m: m["steps"][0].update(f_nominal=[0, 1]), "steps[0].f_nominal: expected [x, y, z]"),
    (lambda m: m["rig"]["sensor"].update(sample_rate_hz="fast"), "rig.sensor.sample_rate_hz: expected a number, got 'fast'"),
    (lambda m: m["rig"]["sensor"].update(sample_rate_hz=-5), "rig.sensor.sample_rate_hz: expected a number > 0, got -5"),
    (lambda m: m["rig"]["sensor"].pop("accel_lsb_per_g"), "rig.sensor.accel_lsb_per_g: missing required field"),
    (lambda m: m["rig"].pop("sensor"), "rig.sensor: missing required field"),
    (lambda m: m["rig"].update(site={"field_ut": 50.0}), "rig.site.inclination_deg: missing required field"),
    (lambda m: m.update(status="paused"), "status: expected one of running, complete, aborted"),
    (lambda m: m.pop("steps"), "steps: missing required field"),
    (lambda m: m.update(procedure=[1]), "procedure: expected a mapping"),
])
def test_a_bad_manifest_is_one_line_naming_the_key_path(tmp_path, edit, expect):
    d = _record(tmp_path, _model())
    m = yaml.safe_load((d / "session.yaml").read_text())
    edit(m)
    (d / "session.yaml").write_text(yaml.safe_dump(m, sort_keys=False))
    with pytest.raises(SessionFormatError) as e:
        load_session(d)
    assert str(e.value).startswith(f"{d / 'session.yaml'}: {expect}") and "\n" not in str(e.value)


def test_a_writer_refuses_a_manifest_it_could_not_read_back(tmp_path):
    m = _mapping()
    m["steps"][0]["status"] = "weird"
    with pytest.raises(SessionFormatError, match=r"steps\[0\].status"):
        SessionWriter.create(tmp_path, "s", m)
    assert not (tmp_path / "s").exists()
