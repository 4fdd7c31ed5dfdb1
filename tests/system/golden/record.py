"""Record the golden outputs that ``tests/system/test_golden.py`` compares against.

Run once, on the code before a refactor, to pin what the ``rig`` command produces; rerun only when
a change of results is intended (and say so in the commit)::

    .venv/bin/python tests/system/golden/record.py

Each scenario is a list of ``rig`` commands; its outputs (calibration files, discover JSON,
evaluation JSON) are stored here with the run-dependent fields (creation time, session id, paths)
removed by :func:`normalise`.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[2]
DATASETS = REPO.parent / "shared" / "datasets"
SEED = 3

#: procedures run on the simulated rig in virtual time (name -> extra options)
RUNS = ["six_position", "twelve_position", "thermal", "verify_seed_table", "tumble26", "gyro_rates",
        "mag_eight_position", "mag_tumble"]
#: re-solves of a recorded session: (golden name, session procedure, rig solve options)
SOLVES = [("twelve_position_flip", "twelve_position", ["--method", "flip"]),
          ("twelve_position_combinations", "twelve_position", ["--method", "combinations"]),
          ("twelve_position_full", "twelve_position", ["--model", "full"]),
          ("thermal_off", "thermal", ["--thermal", "off"])]
#: imported recordings: (golden name, source, file under shared/datasets, rig solve options)
IMPORTS = [("import_imucal", "imucal", "imucal/annotated_session.csv", [], True),
           ("import_imu_tk", "imu_tk", "imu_tk-xsens/xsens_acc.txt", ["--method", "magnitude"], True),
           ("import_tofupilot", "tofupilot", "tofupilot-thermal/imu_raw_data.csv", None, True)]
VOLATILE = {"created", "session", "calibration", "session_dir", "path"}


def rig(*args: str) -> str:
    """Run ``rig ARGS`` and return its standard output (raise on a non-zero exit)."""
    proc = subprocess.run([sys.executable, "-m", "rig.cli", *args], capture_output=True, text=True,
                          cwd=REPO, timeout=900)
    if proc.returncode != 0:
        raise RuntimeError(f"rig {' '.join(args)} -> {proc.returncode}: {proc.stderr.strip()}")
    return proc.stdout


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


def record_runs(out: Path) -> dict[str, object]:
    golden: dict[str, object] = {}
    for name in RUNS:
        rig("run", str(REPO / "procedures" / f"{name}.yaml"), "--seed", str(SEED), "--time-scale", "0",
            "--out", str(out), "--quiet", "--yes")
        calibration = session_dir(out, name) / "calibration.yaml"
        if calibration.exists():  # verify_seed_table has no solve
            golden[f"run_{name}"] = yaml.safe_load(calibration.read_text())
    six = session_dir(out, "six_position")
    rig("replay", str(six), "--out", str(out / "replayed"))
    (replayed,) = sorted((out / "replayed").glob("*"))
    golden["replay_six_position"] = yaml.safe_load((replayed / "calibration.yaml").read_text())
    for name, procedure, options in SOLVES:
        target = out / f"{name}.yaml"
        rig("solve", str(session_dir(out, procedure)), "-o", str(target), *options)
        golden[f"solve_{name}"] = yaml.safe_load(target.read_text())
    golden["discover_tumble26"] = json.loads(rig("discover", str(session_dir(out, "tumble26")), "--json"))
    verify = session_dir(out, "verify_seed_table")
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


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        golden = record_runs(Path(tmp) / "runs")
        golden.update(record_imports(Path(tmp) / "imports"))
    for name, content in golden.items():
        (HERE / f"{name}.json").write_text(json.dumps(normalise(content), indent=1, sort_keys=True) + "\n")
        print(f"recorded {name}")


if __name__ == "__main__":
    main()
