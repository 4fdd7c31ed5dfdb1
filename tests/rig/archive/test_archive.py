"""Sessions in a Parquet archive and solved again at scale (issue 31 items 1-2): the archive is idempotent, gives
any session back as a directory whose seal verifies and which solves to the same calibration; ``rig resolve``
gives the same results serially and on a process pool, goes on where a killed run stopped, records a session that
cannot be solved as a failed row, and every bad input is one line, exit 2."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from rig.analysis.solve import calibrate_session
from rig.archive.resolve import read_results, resolve_archive
from rig.archive.store import archive_sessions, extract_session
from rig.session import load_session

from conftest import PROCEDURES
from cli_run import rig_in_process as _rig


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    """Three simulated units' six-position sessions and a magnetometer-only import (it has no accelerometer)."""
    root = tmp_path_factory.mktemp("sessions")
    out = []
    for seed in (1, 2, 3):
        code, _, err = _rig("run", PROCEDURES / "six_position.yaml", "--seed", seed, "--time-scale", 0, "--quiet",
                            "--out", root / f"s{seed}")
        assert code == 0, err
        out.append(next((root / f"s{seed}").iterdir()))
    csv = root / "mag.csv"
    t = np.arange(500) / 100.0
    m = np.stack([40 * np.cos(t), 40 * np.sin(t), 20 + 0 * t], axis=1)
    csv.write_text("# mag_units: uT\nt_s,mx,my,mz\n" + "\n".join(f"{a:.2f},{b:.3f},{c:.3f},{d:.3f}"
                                                                for a, (b, c, d) in zip(t, m)) + "\n")
    assert _rig("import", "--from", "csv", csv, "-o", root / "imp", "--continuous", "--id", "mag-only")[0] == 0
    return out + [root / "imp" / "mag-only"]


@pytest.fixture(scope="module")
def archive(sessions, tmp_path_factory):
    path = tmp_path_factory.mktemp("archive") / "a"
    report = archive_sessions(sessions, path, lot="L7")
    assert len(report.added) == 4 and not report.refused
    return path


def test_appending_again_adds_nothing_and_a_changed_recording_is_refused(sessions, archive, tmp_path):
    again = archive_sessions(sessions, archive)
    assert again.added == [] and len(again.skipped) == 4
    resolved = tmp_path / "resolved" / sessions[0].name  # re-solved since: a calibration file more, the same recording
    shutil.copytree(sessions[0], resolved)
    (resolved / "calibration-resolved.yaml").write_text((resolved / "calibration.yaml").read_text())
    assert archive_sessions([resolved], archive).skipped == [sessions[0].name]
    changed = tmp_path / "changed" / sessions[0].name  # its samples edited: its seal no longer holds
    shutil.copytree(sessions[0], changed)
    text = (changed / "samples.csv").read_text()
    (changed / "samples.csv").write_text(text.replace(",8", ",9", 1))
    refused = archive_sessions([changed], archive).refused
    assert len(refused) == 1 and str(changed) in refused[0], refused


def test_a_session_comes_back_as_it_was_its_seal_verifies_and_it_solves_the_same(sessions, archive, tmp_path):
    original = sessions[1]
    back = extract_session(archive, original.name, tmp_path)
    assert (back / "samples.csv").read_bytes() == (original / "samples.csv").read_bytes()
    for name in ("session.yaml", "events.jsonl", "sim_truth.yaml"):
        assert (back / name).read_bytes() == (original / name).read_bytes()
    assert load_session(back).warnings == []  # the seal verifies
    a, b = (calibrate_session(p).accelerometer for p in (original, back))
    assert np.array_equal(a.bias_counts, b.bias_counts) and np.array_equal(a.scale_counts_per_g, b.scale_counts_per_g)


def test_serial_and_processes_give_the_solves_of_rig_solve_and_a_failed_row_for_what_cannot_be_solved(
        sessions, archive, tmp_path):
    serial = resolve_archive(archive, tmp_path / "serial", executor="serial", chunk=2)
    pooled = resolve_archive(archive, tmp_path / "pool", executor="processes", workers=2, chunk=2)
    assert serial.chunks_solved == pooled.chunks_solved == 2 and serial.sessions == 4
    a, b = read_results(tmp_path / "serial"), read_results(tmp_path / "pool")
    np.testing.assert_array_equal(np.array(a.column("bias_counts").to_pylist()),
                                  np.array(b.column("bias_counts").to_pylist()))  # NaN in the failed row on both
    rows = {r["session_id"]: r for r in a.to_pylist()}
    for s in sessions[:3]:
        cal = calibrate_session(s).accelerometer
        assert rows[s.name]["ok"] and rows[s.name]["bias_counts"] == [float(x) for x in cal.bias_counts]
    failed = rows["mag-only"]
    assert not failed["ok"] and "accelerometer" in failed["reason"]
    assert [sid for sid, _ in serial.failed] == ["mag-only"]


def test_a_killed_run_goes_on_where_it_stopped(archive, tmp_path):
    first = resolve_archive(archive, tmp_path / "r", executor="serial", chunk=1)
    assert first.chunks_solved == 4
    chunks = sorted((tmp_path / "r").glob("chunk-*.parquet"))
    chunks[1].unlink()  # the chunk a killed worker never wrote
    (tmp_path / "r" / f".{chunks[1].name}.partial").write_bytes(b"PAR1 cut short")  # and its half-written file
    again = resolve_archive(archive, tmp_path / "r", executor="serial", chunk=1)
    assert again.chunks_solved == 1 and again.chunks_done_before == 3
    assert read_results(tmp_path / "r").num_rows == 4


def test_bad_inputs_are_one_line_and_exit_2(archive, tmp_path):
    code, _, err = _rig("resolve", archive, "-o", tmp_path / "r")
    assert code == 0
    code, _, err = _rig("resolve", archive, "-o", tmp_path / "r", "--model", "full")  # other options, same folder
    assert code == 2 and "solved with" in err and len(err.strip().splitlines()) == 1
    code, _, err = _rig("archive", "--extract", "no-such-session", archive, "-o", tmp_path / "x")
    assert code == 2 and "is not in the archive" in err
    code, _, err = _rig("resolve", tmp_path, "-o", tmp_path / "r2")
    assert code == 2 and "not a session archive" in err
    damaged = tmp_path / "damaged"
    shutil.copytree(archive, damaged)
    part = next((damaged / "samples").rglob("*.parquet"))
    part.write_bytes(part.read_bytes()[:200])  # a Parquet file cut short
    code, _, err = _rig("archive", "--extract", "mag-only", damaged, "-o", tmp_path / "y")
    assert code == 2 and ("damaged" in err or "not a readable archive" in err), err
    assert len(err.strip().splitlines()) == 1
    code, _, err = _rig("archive", tmp_path, "-o", tmp_path / "a2")
    assert code == 2 and "not a session directory" in err


def test_a_two_worker_dask_cluster_gives_the_serial_rows(archive, tmp_path):
    serial = resolve_archive(archive, tmp_path / "serial", executor="serial", chunk=2)
    on_dask = resolve_archive(archive, tmp_path / "dask", executor="dask", workers=2, chunk=2, dask_processes=False)
    assert on_dask.chunks_solved == serial.chunks_solved == 2
    assert [s for s, _ in on_dask.failed] == ["mag-only"]
    a, b = read_results(tmp_path / "serial"), read_results(tmp_path / "dask")
    assert a.column("session_id").to_pylist() == b.column("session_id").to_pylist()
    np.testing.assert_array_equal(np.array(a.column("bias_counts").to_pylist()),
                                  np.array(b.column("bias_counts").to_pylist()))


def test_fleet_statistics_per_lot_and_the_units_that_stand_out(archive, tmp_path):
    from rig.archive.fleet import fleet
    resolve_archive(archive, tmp_path / "r", executor="serial", chunk=4)
    (group,) = fleet(tmp_path / "r", by="lot")
    assert group.group == "L7" and group.n == 3 and group.failed == 1  # the magnetometer-only session: not used
    rows = [r for r in read_results(tmp_path / "r").to_pylist() if r["ok"]]
    assert group.parameters["bias_x"]["median"] == float(np.median([r["bias_counts"][0] for r in rows]))
    assert group.parameters["scale_z"]["unit"] == "counts/g" and group.parameters["bias_y"]["spread"] > 0
    (loose,) = fleet(tmp_path / "r", threshold=0.5)  # three units: at 0.5 robust sigmas someone stands out
    assert loose.outliers and all(abs(o["z"]) > 0.5 for o in loose.outliers)
    code, out, _ = _rig("fleet", tmp_path / "r", "--by", "lot")
    assert code == 0 and out.startswith("lot L7: 3 units solved, 1 failed")
    code, _, err = _rig("fleet", tmp_path)
    assert code == 2 and "no results" in err


def test_the_change_of_every_parameter_after_a_re_solve_in_combined_sigmas(archive, tmp_path):
    from rig.archive.fleet import changes
    resolve_archive(archive, tmp_path / "old", executor="serial", chunk=4)
    resolve_archive(archive, tmp_path / "new", executor="serial", chunk=4, model="full")
    found = {c.parameter: c for c in changes(tmp_path / "new", tmp_path / "old")}
    assert set(found) == {f"{p}_{a}" for p in ("bias", "scale") for a in "xyz"}
    assert all(c.n == 3 for c in found.values())  # the three solved in both (not the magnetometer-only one)
    new, old = (read_results(tmp_path / d).to_pylist() for d in ("new", "old"))
    d = np.mean([n["bias_counts"][0] - o["bias_counts"][0] for n, o in zip(new, old) if n["ok"] and o["ok"]])
    assert found["bias_x"].mean == pytest.approx(d)
    code, out, _ = _rig("fleet", tmp_path / "new", "--against", tmp_path / "old")
    assert code == 0 and "over 3 sessions solved in both" in out
