"""Sealed sessions (issue 34 item 6; docs/session-format.md, "Seal"): each step's rows are chained into its
stats as they are recorded, the whole record is sealed at completion, and a session that differs from its
seal is refused on load naming the file and the first step that differs (RIG_UNSEALED=1: loaded, warned,
marked). Sessions are written with SessionWriter directly (no simulator): a six-position recording."""

from __future__ import annotations

import hashlib
import json
import shutil

import numpy as np
import pytest
import yaml

from rig.errors import SessionFormatError
from rig.lab.history import open_history, record_seal
from rig.session import SessionManifest, SessionWriter, load_session
from rig.session.seal import BROKEN_MARK, SealBroken, seal_digest, seal_session, verify_session
from rig.workflow.conclude import conclude

from conftest import PROCEDURES, scale_counts

FACES = [[0, 0, 1], [1, 0, 0], [0, 0, -1], [-1, 0, 0], [0, 1, 0], [0, -1, 0]]
N = 300


def _manifest(extra: dict | None = None) -> dict:
    text = (PROCEDURES / "six_position.yaml").read_text()
    return {"procedure": {"name": "six_position", "file": "procedures/six_position.yaml", "text": text},
            "software": {"name": "rig", "version": "test"},
            "rig": {"sensor": {"model": "MPU-9150", "address": 104, "serial": "T1", "accel_lsb_per_g": 8192.0,
                               "accel_range_g": 4, "sample_rate_hz": 100.0, "has_temperature": True}},
            "steps": [{"index": i, "name": f"p{i}", "kind": "static", "angles_deg": None, "f_nominal": f,
                       "status": "pending"} for i, f in enumerate(FACES)], **(extra or {})}


def _write_steps(writer: SessionWriter, steps) -> None:
    rng = np.random.default_rng(3)
    for i in steps:
        counts = np.round(np.array(FACES[i]) * 8150 + [60, -40, 110] + rng.normal(0, 25, (N, 3))).astype(int)
        writer.event("move", step=i, to_deg=[0, 0, 0])
        writer.append_samples(i, i * 10 + np.arange(N) * 0.01, counts, temp_c=np.full(N, 25.0),
                              angles_deg=np.zeros((N, 3)))
        writer.complete_step(i, {"n_samples": N})
        writer.event("capture", step=i, n_samples=N)


def record(root, session_id="six", extra: dict | None = None):
    writer = SessionWriter.create(root, session_id, _manifest(extra))
    _write_steps(writer, range(6))
    writer.set_status("complete")
    return root / session_id


@pytest.fixture(scope="module")
def sealed(tmp_path_factory):
    """A complete six-position session (read only: tests copy it to change it)."""
    return record(tmp_path_factory.mktemp("sealed"))


@pytest.fixture
def copy(sealed, tmp_path):
    d = tmp_path / sealed.name
    shutil.copytree(sealed, d)
    return d


def _doc(d) -> dict:
    return yaml.safe_load((d / "session.yaml").read_text())


def _rewrite_manifest(d, change) -> None:
    """Change a field in session.yaml's text (the seal stays as it was)."""
    path = d / "session.yaml"
    path.write_text(change(path.read_text()))


def test_a_completed_session_is_sealed_and_each_step_chained_over_its_rows(sealed):
    doc = _doc(sealed)
    seal = doc["seal"]
    data = (sealed / "samples.csv").read_bytes()
    events = (sealed / "events.jsonl").read_bytes()
    assert seal["algorithm"] == "sha256" and seal["sealed_at"]
    assert seal["samples_sha256"] == hashlib.sha256(data).hexdigest() and seal["samples_bytes"] == len(data)
    assert seal["events_sha256"] == hashlib.sha256(events).hexdigest() and seal["events_bytes"] == len(events)
    assert seal["sha256"] == seal_digest(seal)
    # h_i = sha256(h_{i-1} || rows_i): the exact bytes appended for step i, from the header line's hash
    header_end = data.index(b"\n") + 1
    head, pos = hashlib.sha256(data[:header_end]).digest(), header_end
    for i, step in enumerate(doc["steps"]):
        start, end = step["stats"]["samples_bytes"]
        assert start == pos and data[start:end].count(b"\n") == N
        assert {int(line.split(b",")[1]) for line in data[start:end].splitlines()} == {i}
        head = hashlib.sha256(head + data[start:end]).digest()
        assert step["stats"]["sha256"] == head.hex()
        pos = end
    assert pos == len(data) and seal["chain"] == head.hex()
    found = verify_session(sealed)
    assert found.sealed and found.steps == 6
    s = load_session(sealed)
    assert s.warnings == [] and s.id == "six" and s.info.model_extra["seal"] == seal


def test_counts_scaled_by_1_10_are_refused_naming_samples_csv_and_step_1(copy):
    scale_counts(copy, 1.10)
    with pytest.raises(SealBroken) as exc:
        verify_session(copy)
    assert (exc.value.file, exc.value.key, exc.value.line) == ("samples.csv", "step 1 (index 0 in samples.csv)", 2)
    with pytest.raises(SessionFormatError) as exc:
        load_session(copy)  # every command reads sessions so: solve, evaluate, report, discover, compare, replay
    line = str(exc.value)
    assert "\n" not in line and line.startswith(f"{copy / 'samples.csv'}:2: step 1 (index 0 in samples.csv): ")
    assert "differ from the seal" in line


def test_a_changed_row_in_a_later_step_names_that_step(copy):
    path = copy / "samples.csv"
    lines = path.read_text().splitlines(keepends=True)
    k = 1 + 3 * N + 17  # a row of step 4
    cells = lines[k].split(",")
    cells[2] = str(int(cells[2]) + 1)
    lines[k] = ",".join(cells)
    path.write_text("".join(lines))
    with pytest.raises(SealBroken) as exc:
        verify_session(copy)
    assert (exc.value.file, exc.value.key, exc.value.line) == ("samples.csv", "step 4 (index 3 in samples.csv)",
                                                               2 + 3 * N)


def test_a_row_appended_after_the_seal_is_named(copy):
    with open(copy / "samples.csv", "a") as fh:
        fh.write("60.00000,5,60,-8190,110,25.0000,0.00000,0.00000,0.00000\n")
    with pytest.raises(SealBroken) as exc:
        verify_session(copy)
    assert (exc.value.file, exc.value.key, exc.value.line) == ("samples.csv", "step 6 (index 5 in samples.csv)",
                                                               2 + 6 * N)
    assert "added after the recording was sealed" in str(exc.value)


def test_rows_removed_at_the_end_are_named(copy):
    path = copy / "samples.csv"
    path.write_bytes(path.read_bytes().rsplit(b"\n", 2)[0] + b"\n")
    with pytest.raises(SealBroken) as exc:
        verify_session(copy)
    assert exc.value.file == "samples.csv" and exc.value.key == "step 6 (index 5 in samples.csv)"


def test_an_edited_event_is_named_with_its_step(copy):
    path = copy / "events.jsonl"
    lines = path.read_text().splitlines(keepends=True)
    k = next(i for i, line in enumerate(lines) if json.loads(line).get("step") == 2 and "move" in line)
    lines[k] = lines[k].replace('"move"', '"mave"')
    path.write_text("".join(lines))
    with pytest.raises(SealBroken) as exc:
        verify_session(copy)
    assert exc.value.file == "events.jsonl" and exc.value.key == "step 3"
    with pytest.raises(SessionFormatError, match="events.jsonl"):
        load_session(copy)


def test_an_event_added_after_the_seal_is_named(copy):
    with open(copy / "events.jsonl", "a") as fh:
        fh.write('{"utc": "2030-01-01T00:00:00.000+00:00", "kind": "warning", "step": 4, "message": "x"}\n')
    with pytest.raises(SealBroken) as exc:
        verify_session(copy)
    assert exc.value.file == "events.jsonl" and exc.value.key == "step 5" and "added after" in str(exc.value)


@pytest.mark.parametrize("change, key", [
    (lambda t: t.replace("accel_lsb_per_g: 8192.0", "accel_lsb_per_g: 8958.0"), "rig"),
    (lambda t: t.replace("name: p2\n", "name: p2 (re-labelled)\n"), "steps[2]"),
    (lambda t: t.replace("serial: T1", "serial: T2"), "rig"),
])
def test_an_edited_manifest_field_is_named(copy, change, key):
    _rewrite_manifest(copy, change)
    with pytest.raises(SealBroken) as exc:
        verify_session(copy)
    assert exc.value.file == "session.yaml" and exc.value.key == key


def test_a_changed_step_hash_is_named_as_the_manifest_edit_it_is(copy):
    doc = _doc(copy)
    h = doc["steps"][0]["stats"]["sha256"]
    _rewrite_manifest(copy, lambda t: t.replace(h, "a" * 64, 1))
    with pytest.raises(SealBroken) as exc:
        verify_session(copy)
    assert (exc.value.file, exc.value.key) == ("session.yaml", "steps[0]")


def test_a_changed_seal_is_named(copy):
    seal = _doc(copy)["seal"]
    _rewrite_manifest(copy, lambda t: t.replace(seal["samples_sha256"], "b" * 64))
    with pytest.raises(SealBroken) as exc:
        verify_session(copy)
    assert (exc.value.file, exc.value.key) == ("session.yaml", "seal")


def test_rig_unsealed_loads_a_broken_session_with_a_warning_and_marks_it(copy, monkeypatch):
    scale_counts(copy, 1.10)
    monkeypatch.setenv("RIG_UNSEALED", "1")
    s = load_session(copy)
    assert s.id == "six" + BROKEN_MARK and s.info.id.endswith(".SEAL-BROKEN")
    (warning,) = s.warnings
    assert "samples.csv:2: step 1 (index 0 in samples.csv)" in warning and "RIG_UNSEALED=1" in warning and "six.SEAL-BROKEN" in warning
    assert "step 1" in s.info.model_extra["seal"]["broken"]
    assert s.info.to_dict()["id"] == "six.SEAL-BROKEN"  # what the history and the calibration file are given


def test_a_session_without_a_seal_loads_as_before_and_is_not_sealed(copy):
    text = (copy / "session.yaml").read_text()
    (copy / "session.yaml").write_text(text[:text.index("\nseal:\n") + 1])  # recorded before sealing existed
    s = load_session(copy)
    assert s.warnings == [] and s.id == "six"
    found = verify_session(copy)
    assert not found.sealed and found.steps == 6  # its steps' own hashes are still checked


def test_an_old_session_without_any_hashes_loads(copy):
    doc = _doc(copy)
    doc.pop("seal")
    for step in doc["steps"]:
        for key in ("sha256", "samples_bytes", "events_sha256", "events_bytes"):
            step["stats"].pop(key)
    (copy / "session.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    assert load_session(copy).warnings == []
    found = verify_session(copy)
    assert (found.sealed, found.steps) == (False, 0)


def test_an_aborted_session_is_not_sealed_and_a_resumed_one_chains_on_and_seals(tmp_path):
    w = SessionWriter.create(tmp_path, "res", _manifest())
    _write_steps(w, range(3))
    w.append_samples(3, np.arange(5) * 0.01, np.tile([0, 0, -8192], (5, 1)), temp_c=np.full(5, 25.0),
                     angles_deg=np.zeros((5, 3)))  # the step in progress when it stopped
    w._samples.flush()
    w.set_status("aborted")
    d = tmp_path / "res"
    assert "seal" not in _doc(d) and not verify_session(d).sealed
    w, first = SessionWriter.resume(d)
    assert first == 3
    _write_steps(w, range(3, 6))
    w.set_status("complete")
    found = verify_session(d)
    assert found.sealed and found.steps == 6
    assert load_session(d).warnings == []


def test_a_seal_is_never_replaced(copy):
    before = (copy / "session.yaml").read_bytes()
    assert seal_session(copy) == _doc(copy)["seal"]
    assert (copy / "session.yaml").read_bytes() == before


def test_an_import_records_its_source_file_hash_in_the_seal(tmp_path):
    source = hashlib.sha256(b"the source recording").hexdigest()
    extra = {"import": {"source": "csv", "file": "x.csv", "source_sha256": source}}
    d = record(tmp_path, "imp", extra)
    assert _doc(d)["seal"]["source_sha256"] == source and verify_session(d).sealed
    d2 = tmp_path / "imp2"
    w = SessionWriter.create(tmp_path, "imp2", dict(_manifest({"import": {"source": "csv"}}),
                                                     procedure={"name": "import-csv", "sha256": source}))
    _write_steps(w, range(6))
    w.set_status("complete")
    assert _doc(d2)["seal"]["source_sha256"] == source  # today's importers: the source hash as procedure.sha256


def test_the_history_row_holds_the_seal(copy, tmp_path):
    db = tmp_path / "h.sqlite"
    s = load_session(copy)
    cal = tmp_path / "cal.yaml"
    conclude(s, out=cal, history=db, report=False)
    seal = _doc(copy)["seal"]
    with open_history(db) as h:
        (row,) = h.query("SELECT seal FROM calibrations")
    assert json.loads(row["seal"]) == seal


def test_rows_recorded_before_the_seal_get_it(tmp_path, monkeypatch):
    """rig run solves (and records) before it marks the session complete, which seals it: record_seal fills them."""
    w = SessionWriter.create(tmp_path, "run", _manifest())
    _write_steps(w, range(6))
    db = tmp_path / "h.sqlite"
    cal = tmp_path / "cal.yaml"
    conclude(load_session(tmp_path / "run"), out=cal, history=db, report=False)  # still running: no seal yet
    w.set_status("complete")
    with open_history(db) as h:
        assert h.query("SELECT seal FROM calibrations")[0]["seal"] is None
    assert record_seal(tmp_path / "run", history=db) is None
    with open_history(db) as h:
        (row,) = h.query("SELECT seal FROM calibrations")
    assert json.loads(row["seal"])["sha256"] == _doc(tmp_path / "run")["seal"]["sha256"]


def test_a_broken_seal_analysed_under_rig_unsealed_is_marked_in_the_history_and_the_calibration(copy, tmp_path,
                                                                                                   monkeypatch):
    scale_counts(copy, 1.10)
    monkeypatch.setenv("RIG_UNSEALED", "1")
    db = tmp_path / "h.sqlite"
    out = conclude(load_session(copy), out=tmp_path / "cal.yaml", history=db, report=False)
    assert out.calibration.session == "six.SEAL-BROKEN"
    assert "session: six.SEAL-BROKEN" in (tmp_path / "cal.yaml").read_text()
    with open_history(db) as h:
        (row,) = h.query("SELECT session_id, seal FROM calibrations")
    assert row["session_id"] == "six.SEAL-BROKEN" and "step 1" in json.loads(row["seal"])["broken"]
    assert record_seal(copy, history=db) is None  # a broken seal is never copied onto other rows
    with open_history(db) as h:
        assert "broken" in json.loads(h.query("SELECT seal FROM calibrations")[0]["seal"])


def test_the_manifest_model_keeps_the_seal_and_the_step_hashes(sealed):
    info, doc = SessionManifest.load(sealed)
    assert info.to_dict() == doc
    assert info.steps[0].stats.model_extra["sha256"] == doc["steps"][0]["stats"]["sha256"]
