"""``rig import`` streams its source (issue 34 item 4): memory bounded whatever the file's size, the same
sessions as the whole-file reading gave, and no session left by an import that fails or is killed.

- static detection fed in chunks gives the whole series' intervals to the bit (against the whole-array
  algorithm as it was), and the exact median and pairwise sums over chunks equal numpy's;
- the sessions of the real recordings and of generated files are the same, byte for byte, read in blocks
  of a few hundred characters (every block boundary, the exact reading of odd blocks, the bit-pattern median)
  as in blocks of 4 MiB;
- a ~25 MB CSV imports in a subprocess under 400 MB peak RSS (the whole-file reading grew with the file: 1.4 GB
  at 50 MB; streamed, about 240 MB at 25 MB and 255 MB at 50 MB);
- a failed import (a bad row late in the file; a write that fails half-way) leaves nothing, and a killed one
  (SIGKILL while writing) leaves only its ``.partial`` directory, which the next import of the file removes,
  saying so, before it imports under the same id; a running import's partial directory is left alone.

Against the whole-file reading, every test here fails but the bad row late in the file: that reading wrote
nothing before it had read the whole file, so it left nothing then either (the failing write is the failed
import it left half a session for).
"""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import rig.importers.common as common
from calib.numerics.static_detect import StaticDetector, detect_static
from rig.importers.recordings import import_recording
from rig.session import load_session

from conftest import DATASETS, REPO
from tumble_csv import write_tumble_csv


def _reference_static(t, counts, *, window_s=2.0, init_s=30.0, threshold_factor=6.0, min_s=3.0, trim_s=0.5):
    """calib.numerics.static_detect.detect_static as it was before streaming (whole arrays)."""
    t = np.asarray(t, float)
    a = np.asarray(counts, float)
    dt = float(np.median(np.diff(t)))
    n = max(3, int(round(window_s / dt)))
    c1 = np.cumsum(np.vstack([np.zeros((1, 3)), a]), axis=0)
    c2 = np.cumsum(np.vstack([np.zeros((1, 3)), a * a]), axis=0)
    idx = np.arange(len(a))
    lo, hi = np.clip(idx - n // 2, 0, len(a)), np.clip(idx + n // 2 + 1, 0, len(a))
    cnt = (hi - lo)[:, None]
    mean = (c1[hi] - c1[lo]) / cnt
    var = np.maximum((c2[hi] - c2[lo]) / cnt - mean**2, 0.0).sum(axis=1)
    init = t <= t[0] + init_s
    ref = float(np.median(var[init])) if init.any() else float(np.median(var))
    static = var < threshold_factor * max(ref, 1e-12)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], static.astype(int), [0]])))
    trim = int(round(trim_s / dt))
    out = []
    for s, e in zip(edges[0::2], edges[1::2]):
        s2, e2 = s + trim, e - trim
        if e2 > s2 and t[e2 - 1] - t[s2] >= min_s:
            out.append((int(s2), int(e2)))
    return out


def _series(rng, n: int, rate: float, jitter: float):
    t = 3.7 + np.arange(n) / rate + (rng.uniform(0, jitter, n) if jitter else 0.0)
    a = np.zeros((n, 3)) + [33000.0, 33200.0, 32300.0]
    k = 0
    while k < n:
        m = int(rng.integers(50, 3000))
        a[k:k + m] += rng.normal(0, 3 if rng.random() < 0.6 else 300, (min(m, n - k), 3))
        k += m
    return t, np.rint(a)


def test_static_detection_fed_in_chunks_gives_the_whole_series_intervals():
    rng = np.random.default_rng(5)
    for _ in range(25):
        n = int(rng.integers(5, 30000))
        t, a = _series(rng, n, float(rng.choice([50, 100, 1000])), float(rng.choice([0.0, 1e-4])))
        kw = dict(window_s=float(rng.choice([0.05, 2.0, 5.0])), init_s=float(rng.choice([0.0, 5.0, 30.0, 1e6])),
                  trim_s=float(rng.choice([0.0, 0.5, 4.0])), min_s=float(rng.choice([0.1, 3.0])))
        expected = _reference_static(t, a, **kw)
        assert detect_static(t, a, **kw) == expected
        for chunk in (97, 1000):
            det = StaticDetector(float(np.median(np.diff(t))), float(t[0]), **kw)
            for i in range(0, n, chunk):
                det.feed(t[i:i + chunk], a[i:i + chunk])
            assert det.finish() == expected, (n, kw, chunk)
        # small chunks on the series' first samples (every sample or every 7th a chunk boundary; the whole of a
        # 30,000-sample series fed one sample per call cost 20 s of the suite and crosses no other boundary)
        for chunk, m in ((1, min(n, 1000)), (7, min(n, 4000))):
            tm, am = t[:m], a[:m]
            det = StaticDetector(float(np.median(np.diff(tm))) if m > 1 else 0.01, float(tm[0]), **kw)
            for i in range(0, m, chunk):
                det.feed(tm[i:i + chunk], am[i:i + chunk])
            assert det.finish() == _reference_static(tm, am, **kw), (m, kw, chunk)


def test_the_median_and_the_sums_over_chunks_are_numpys():
    rng = np.random.default_rng(3)
    for n in (1, 2, 3, 1000, 4097, 100_001):
        x = np.abs(rng.normal(0.01, 1e-4, n)) * rng.choice([1.0, 1e-6, 1e6])
        x[rng.random(n) < 0.3] = 0.01  # repeated values, as time stamps' differences are
        pieces = lambda: (x[i:i + 999] for i in range(0, n, 999))
        assert common.exact_median(pieces, n, in_memory=10) == float(np.median(x))
        assert common.pairwise_sum(lambda a, m: x[a:a + m], n, leaf=8) == float(np.sum(x))


# -- the same sessions, read in small blocks ----------------------------------------------------------

def _labelled_csv(path: Path, crlf: bool = False, quoted: bool = False) -> Path:
    rng = np.random.default_rng(1)
    lines = ["# units: counts", "# lsb_per_g: 16384", "t_s,ax,ay,az,temp_c,label"]
    t = 0.0
    labels = {"+X up": [1, 0, 0], "-X up": [-1, 0, 0], "+Y up": [0, 1, 0], "-Y up": [0, -1, 0], "+Z up": [0, 0, 1],
              "-Z up": [0, 0, -1], "rot x": [0, 0, 1]}
    if quoted:  # a quote inside a field is a character; a quoted field may hold commas and line ends
        labels.update({'tilt 5" plate': [0, 0, 1], '"on edge, then\nflat"': [0, 0, 1]})
    for name, f in labels.items():
        for k in range(80):
            a = np.round(np.array(f) * 16384 + 100 + rng.normal(0, 5, 3)).astype(int)
            label = f'"{name}"' if quoted and k % 3 == 0 and '"' not in name else name
            lines.append(f"{t:.3f},{a[0]},{a[1]},{a[2]},{25 + rng.normal(0, 0.1):.3f},{label}")
            if k == 40:
                lines.append("")  # a blank line
            t += 0.01
    path.write_bytes(("\r\n" if crlf else "\n").join(lines).encode() + b"\n")
    return path


def _sources(tmp: Path) -> list[tuple[str, Path]]:
    write_tumble_csv(tmp / "tumble.csv", 2e6)
    found = [("csv", tmp / "tumble.csv"), ("csv", _labelled_csv(tmp / "lab.csv")),
             ("csv", _labelled_csv(tmp / "crlf.csv", crlf=True, quoted=True))]
    for source, rel in (("imucal", "imucal/annotated_session.csv"), ("imu_tk", "imu_tk-xsens/xsens_acc.txt"),
                        ("tofupilot", "tofupilot-thermal/imu_raw_data.csv")):
        if (DATASETS / rel).is_file():
            found.append((source, DATASETS / rel))
    return found


def _without_times(session: Path) -> tuple[bytes, dict, list[str]]:
    import yaml

    doc = yaml.safe_load((session / "session.yaml").read_text())
    for key in ("created", "ended", "seal"):  # times, and what hashes them
        doc.pop(key, None)
    for step in doc["steps"]:  # what the import measured (not the writer's hashes of the events' times)
        step["stats"] = {k: step["stats"][k] for k in ("n_samples", "t_start_s", "t_end_s", "temp_c")}
    events = [json.dumps({k: v for k, v in json.loads(line).items() if k != "utc"})
              for line in (session / "events.jsonl").read_text().splitlines()]
    return (session / "samples.csv").read_bytes(), doc, events


def test_small_blocks_and_chunks_give_the_same_sessions(tmp_path, monkeypatch):
    sources = _sources(tmp_path)
    whole = [import_recording(s, p, tmp_path / "big", f"s{k}") for k, (s, p) in enumerate(sources)]
    monkeypatch.setattr(common, "BLOCK_CHARS", 601)
    monkeypatch.setattr(common, "CHUNK_ROWS", 333)
    monkeypatch.setattr(common, "MEDIAN_IN_MEMORY", 10)
    small = [import_recording(s, p, tmp_path / "small", f"s{k}") for k, (s, p) in enumerate(sources)]
    for a, b in zip(whole, small):
        assert _without_times(a) == _without_times(b), a


# -- memory, failures and kills, in subprocesses -----------------------------------------------------

def _rig(*args: str, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "rig.cli", *map(str, args)], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


def _finish(proc: subprocess.Popen) -> tuple[int, str, str]:
    """Exit code, stdout and stderr of a child started by :func:`_rig` (its few lines wait in the pipes)."""
    _, status, _ = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    out, err = proc.stdout.read(), proc.stderr.read()
    proc.stdout.close()
    proc.stderr.close()
    return proc.returncode, out, err


#: runs the command given, then prints its children's peak RSS (kB) as its last line. The import is started from
#: this small process, not from the test's: a child started by vfork (as subprocess does) carries its parent's
#: high-water mark through exec into its ru_maxrss, and a test worker's is hundreds of MB
MEASURE = ("import resource, subprocess, sys\n"
           "code = subprocess.call(sys.argv[1:])\n"
           "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
           "sys.exit(code)\n")


def _sessions(out: Path) -> list[Path]:
    return sorted(d for d in out.iterdir() if (d / "session.yaml").exists()) if out.exists() else []


@pytest.mark.slow
def test_a_25_mb_csv_imports_in_bounded_memory(tmp_path):
    """The whole-file reading peaked at 1386 MB on a 50 MB file (1.6 M rows), growing with the file; streamed, about
    240 MB on this one (0.8 M rows, 6 blocks of the reader's 4 MiB) and 255 MB on the 50 MB one."""
    src = tmp_path / "tumble.csv"
    info = write_tumble_csv(src, 25e6)
    proc = subprocess.run([sys.executable, "-c", MEASURE, sys.executable, "-m", "rig.cli", "import", "--from", "csv",
                           str(src), "-o", str(tmp_path / "s")], cwd=REPO, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    rss = int(proc.stdout.split()[-1]) / 1024.0
    assert rss < 400, f"peak RSS {rss:.0f} MB for {info['bytes'] / 1e6:.0f} MB"
    (session,) = _sessions(tmp_path / "s")
    assert sum(st.stats.n_samples for st in load_session(session).info.steps) > 0.9 * info["rows"]


def test_a_bad_row_late_in_the_file_leaves_nothing(tmp_path):
    src = tmp_path / "tumble.csv"
    info = write_tumble_csv(src, 3e6)
    with open(src, "a") as fh:
        fh.write("99999.0,1,2,three,25.0\n")
    proc = _rig("import", "--from", "csv", src, "-o", tmp_path / "s")
    code, out, err = _finish(proc)
    assert code == 2 and f"tumble.csv:{info['rows'] + 4}: az: expected a number, got 'three'" in err, err
    assert not (tmp_path / "s").exists() or not any((tmp_path / "s").iterdir())


def _no_bigger_files(limit: int):
    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails (EFBIG) instead of killing
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def test_an_import_failing_while_it_writes_leaves_nothing_and_the_retry_imports(tmp_path):
    """samples.csv cannot grow past a limit (the disk full, say): the import fails half-way through writing
    the session. Before, that left a session with status aborted that blocked the retry."""
    src = tmp_path / "tumble.csv"
    info = write_tumble_csv(src, 8e6)
    # past the spool's largest file (24 bytes a row), short of samples.csv (about 36 bytes a row)
    proc = _rig("import", "--from", "csv", src, "-o", tmp_path / "s",
                preexec_fn=_no_bigger_files(24 * info["rows"] + (1 << 20)))
    code, out, err = _finish(proc)
    assert code != 0 and "File too large" in err, (out, err)
    assert not (tmp_path / "s").exists() or not any((tmp_path / "s").iterdir())
    code, out, err = _finish(_rig("import", "--from", "csv", src, "-o", tmp_path / "s"))
    assert code == 0, err
    assert [d.name for d in (tmp_path / "s").iterdir()] == ["import-csv-tumble"]


@pytest.mark.realtime
def test_a_killed_import_leaves_no_session_and_the_next_import_removes_its_partial(tmp_path):
    src = tmp_path / "tumble.csv"
    write_tumble_csv(src, 12e6)
    out = tmp_path / "s"
    proc = _rig("import", "--from", "csv", src, "-o", out)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:  # kill -9 once the session is being written
        try:
            if any(p.stat().st_size > 1 << 20 for p in out.glob("**/samples.csv")):
                break
        except OSError:  # a directory or file renamed or removed while looked at
            pass
        time.sleep(0.02)
    assert proc.poll() is None, "the import ended before it could be killed"
    proc.send_signal(signal.SIGKILL)
    code, _, _ = _finish(proc)
    assert code == -signal.SIGKILL
    assert _sessions(out) == []
    (left,) = list(out.iterdir())
    assert left.name.endswith(".partial") and left.name.startswith("import-csv-tumble.")
    code, stdout, err = _finish(_rig("import", "--from", "csv", src, "-o", out))
    assert code == 0, err
    notes = [line for line in stdout.splitlines() if line.startswith("note: removed")]
    assert len(notes) == 1 and str(left) in notes[0], stdout
    assert [d.name for d in out.iterdir()] == ["import-csv-tumble"]
    session = load_session(out / "import-csv-tumble")
    assert session.info.status == "complete" and len(session.info.steps) == 26


def test_a_running_imports_partial_is_left_alone_a_dead_ones_removed(tmp_path):
    """A partial directory whose lock is held (an import running now) is never touched; once its lock is free
    (the import was killed) the next import of the same file removes it and says so."""
    import fcntl

    src = _labelled_csv(tmp_path / "lab.csv")
    out = tmp_path / "s"
    other = out / "import-csv-lab.999999.partial"
    other.mkdir(parents=True)
    with open(other / "import.lock", "w") as lock:
        fcntl.flock(lock.fileno(), fcntl.LOCK_EX)
        lock.write(json.dumps({"id": "import-csv-lab", "file": str(src.resolve()), "pid": 999999}))
        lock.flush()
        notes: list[str] = []
        first = import_recording("csv", src, out, notify=notes.append)
        assert notes == [] and other.is_dir() and first == out / "import-csv-lab"
    second = import_recording("csv", src, out, "again", notify=notes.append)
    assert notes == [f"removed {other}: the partial session left by a killed import of {src.resolve()}"]
    assert sorted(d.name for d in out.iterdir()) == ["again", "import-csv-lab"] and second == out / "again"
    with pytest.raises(FileExistsError):
        import_recording("csv", src, out, "again")
    assert sorted(d.name for d in out.iterdir()) == ["again", "import-csv-lab"]
