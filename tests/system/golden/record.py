"""Record the golden outputs that ``tests/system/test_golden.py`` compares against.

Run once, on the code before a refactor, to pin what the ``rig`` command produces; rerun only when
a change of results is intended (and say so in the commit)::

    .venv/bin/python tests/system/golden/record.py

Each scenario is a list of ``rig`` commands; its outputs (calibration files, discover JSON,
evaluation JSON) are stored here with the run-dependent fields (creation time, session id, paths)
removed by :func:`normalise`, and with the Python, numpy and scipy that produced them
(``_recorded_with``: the comparison names both sides' versions when a number differs).

The commands run in this process (``rig.cli.main``), as the tests run them: a subprocess per command
proved nothing more (virtual time, seeded draws: the same numbers bit for bit) and cost an
interpreter start and the numeric imports twenty-five times (issue 26). The recording uses a
calibration history of its own, never the user's.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import platform
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy
import yaml

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[2]
if str(REPO) not in sys.path:  # run as a script: the checkout's packages
    sys.path.insert(0, str(REPO))

from rig.cli import main as rig_main  # noqa: E402 - after the checkout is on the path

DATASETS = REPO.parent / "shared" / "datasets"
SEED = 3
#: the key of every golden file that says what recorded it (not an output: never compared)
META = "_recorded_with"

#: procedures run on the simulated rig in virtual time (name -> extra options)
RUNS = ["six_position", "twelve_position", "thermal", "verify_seed_table", "tumble26", "gyro_rates",
        "mag_eight_position", "mag_tumble"]
#: re-solves of a recorded session: (golden name, session procedure, rig solve options)
SOLVES = [("twelve_position_flip", "twelve_position", ["--method", "flip"]),
          ("twelve_position_combinations", "twelve_position", ["--method", "combinations"]),
          ("twelve_position_full", "twelve_position", ["--model", "full"]),
          ("thermal_off", "thermal", ["--thermal", "off"])]
#: imported recordings: (golden name, source, file under shared/datasets, rig solve options)
IMPORTS = [("import_imucal", "imucal", "imucal/annotated_session.csv", ["--trust-poses"], True),
           ("import_imu_tk", "imu_tk", "imu_tk-xsens/xsens_acc.txt", ["--method", "magnitude"], True),
           ("import_tofupilot", "tofupilot", "tofupilot-thermal/imu_raw_data.csv", None, True)]
#: run-dependent keys, dropped before comparing: ``headline`` (rig discover --json) names the session's path in
#: the command it suggests, and its words are made from keys compared here (effects, gap_closed, aliases)
VOLATILE = {"created", "session", "calibration", "session_dir", "path", "headline"}


def rig(*args: str) -> str:
    """Run ``rig ARGS`` in this process and return its standard output (raise on a non-zero exit)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = rig_main([str(a) for a in args])
    if code != 0:
        raise RuntimeError(f"rig {' '.join(map(str, args))} -> {code}: {err.getvalue().strip()}")
    return out.getvalue()


def recorded_with() -> dict[str, str]:
    """What produced the numbers: Python, numpy, scipy, the BLAS numpy was built with, the machine."""
    blas = np.show_config(mode="dicts").get("Build Dependencies", {}).get("blas", {})
    return {"python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
            "blas": f"{blas.get('name', '?')} {blas.get('version', '?')}", "machine": platform.machine()}


def normalise(obj):
    """Drop run-dependent keys (time of creation, session ids, paths) recursively."""
    if isinstance(obj, dict):
        return {k: normalise(v) for k, v in obj.items() if k not in VOLATILE}
    if isinstance(obj, list):
        return [normalise(v) for v in obj]
    return obj


def session_dir(out: Path, procedure: str) -> Path:
    (found,) = sorted(out.glob(f"{procedure}-*"))
    return found


def record_runs(out: Path, names: list[str] = RUNS) -> dict[str, object]:
    """The runs of ``names`` (of :data:`RUNS`) and what is derived from them: the replay and the evaluation
    of six_position (the evaluation also needs verify_seed_table), the re-solves of :data:`SOLVES` whose
    session was recorded, the discover output of tumble26."""
    golden: dict[str, object] = {}
    for name in names:
        rig("run", str(REPO / "procedures" / f"{name}.yaml"), "--seed", str(SEED), "--time-scale", "0",
            "--out", str(out), "--quiet", "--yes")
        calibration = session_dir(out, name) / "calibration.yaml"
        if calibration.exists():  # verify_seed_table has no solve
            golden[f"run_{name}"] = yaml.safe_load(calibration.read_text())
    if "six_position" in names:
        six = session_dir(out, "six_position")
        rig("replay", str(six), "--out", str(out / "replayed"))
        (replayed,) = sorted((out / "replayed").glob("*"))
        golden["replay_six_position"] = yaml.safe_load((replayed / "calibration.yaml").read_text())
    for name, procedure, options in SOLVES:
        if procedure in names:
            target = out / f"{name}.yaml"
            rig("solve", str(session_dir(out, procedure)), "-o", str(target), *options)
            golden[f"solve_{name}"] = yaml.safe_load(target.read_text())
    if "tumble26" in names:
        golden["discover_tumble26"] = json.loads(rig("discover", str(session_dir(out, "tumble26")), "--json"))
    if "six_position" in names and "verify_seed_table" in names:
        six, verify = session_dir(out, "six_position"), session_dir(out, "verify_seed_table")
        golden["evaluate_verify_seed_table"] = json.loads(
            rig("evaluate", str(six / "calibration.yaml"), str(verify), "--json"))
    return golden


def record_imports(out: Path) -> dict[str, object]:
    golden: dict[str, object] = {}
    for name, source, rel, options, discover in IMPORTS:
        src = DATASETS / rel
        rig("import", "--from", source, str(src), "-o", str(out), "--id", name)
        if options is not None:  # one pose only (tofupilot): nothing to solve, discover only
            target = out / f"{name}.yaml"
            rig("solve", str(out / name), "-o", str(target), *options)
            golden[name] = yaml.safe_load(target.read_text())
        if discover:  # imu_tk: the magnitude baseline (poses unknown, never repeated)
            golden[f"discover_{name}"] = json.loads(rig("discover", str(out / name), "--json"))
    return golden


def record_all(out: Path, runs: list[str] = RUNS, imports: bool = True) -> dict[str, object]:
    """The golden outputs (normalised) of ``runs`` (:func:`record_runs`) and, with ``imports``, of the
    imported recordings, produced under ``out`` with a calibration history of its own."""
    previous = os.environ.get("RIG_HISTORY")
    os.environ["RIG_HISTORY"] = str(out / "history.sqlite")
    try:
        golden = record_runs(out / "runs", runs)
        if imports:
            golden.update(record_imports(out / "imports"))
    finally:
        if previous is None:
            os.environ.pop("RIG_HISTORY", None)
        else:
            os.environ["RIG_HISTORY"] = previous
    return {name: normalise(value) for name, value in golden.items()}


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        golden = record_all(Path(tmp))
    meta = recorded_with()
    for name, content in golden.items():
        (HERE / f"{name}.json").write_text(json.dumps({META: meta, **content}, indent=1, sort_keys=True) + "\n")
        print(f"recorded {name}")


if __name__ == "__main__":
    main()
