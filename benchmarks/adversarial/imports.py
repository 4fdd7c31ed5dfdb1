"""Attack class: recordings given to ``rig import`` (imucal, generic CSV, imu_tk, tofupilot): empty, garbage, huge
fields, wrong values, mislabelled poses, bad options, and a gyroscope file imported as accelerometer data (then
solved: a calibration must not come out)."""

from __future__ import annotations

import os
import random
from pathlib import Path

import yaml

from . import runner
from .runner import DATASETS, Case, classify, first_line, stderr_lines


def _imucal_rows(n=40, part_data=None) -> str:
    parts = {"x_p": (2048, 0, 0), "x_a": (-2048, 0, 0), "y_p": (0, 2048, 0), "y_a": (0, -2048, 0),
             "z_p": (0, 0, 2048), "z_a": (0, 0, -2048)}
    parts.update(part_data or {})
    lines = ["part,samples,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z"]
    k = 0
    for part, (x, y, z) in parts.items():
        for i in range(n):
            lines.append(f"{part},{k},{x + i % 3}.0,{y - i % 2}.0,{z + i % 5}.0,1.0,0.0,-1.0")
            k += 1
    return "\n".join(lines) + "\n"


def _csv_rows(labels=(("+X up", (1, 0, 0)), ("-X up", (-1, 0, 0)), ("+Y up", (0, 1, 0)), ("-Y up", (0, -1, 0)),
                      ("+Z up", (0, 0, 1)), ("-Z up", (0, 0, -1))), n=50, units="g") -> str:
    rng = random.Random(1)
    lines = [f"# units: {units}", "t_s,ax,ay,az,temp_c,label"]
    t = 0.0
    for label, f in labels:
        for _ in range(n):
            v = [c * 1.01 + 0.02 + rng.gauss(0, 1e-3) for c in f]
            lines.append(f"{t:.3f},{v[0]:.6f},{v[1]:.6f},{v[2]:.6f},25.0,{label}")
            t += 0.01
    return "\n".join(lines) + "\n"


def _imu_tk_rows(n=3000) -> str:
    rng = random.Random(2)
    return "".join(f"{0.01 * i:.5f} {33100 + rng.randint(-5, 5)} {33300 + rng.randint(-5, 5)} "
                   f"{36430 + rng.randint(-5, 5)}\n" for i in range(n))


def _tofu_rows(n=600) -> str:
    head = "timestamp\timu.gyro.x\timu.gyro.y\timu.gyro.z\timu.acc.x\timu.acc.y\timu.acc.z\timu.status\timu.temperature"
    rows = [f"{1000000 + i * 500000}\t0.01\t0.0\t0.0\t0.17\t-0.1\t-9.6\t0\t{25 + i * 0.01:.3f}" for i in range(n)]
    return "\n".join([head] + rows) + "\n"


def cases(ws, rng, quick: bool) -> list[Case]:
    good = {"imucal": _imucal_rows(), "csv": _csv_rows(), "imu_tk": _imu_tk_rows(), "tofupilot": _tofu_rows()}
    muts: list[tuple[str, str, str, str | bytes, list]] = []  # (source, name, expect, content, extra args)
    for src, text in good.items():
        lines = text.splitlines(keepends=True)
        first_data = 2 if src == "csv" else (0 if src == "imu_tk" else 1)
        muts += [
            (src, "control: valid recording", "valid", text, []),
            (src, "empty file", "refuse", "", []),
            (src, "header only", "refuse", "".join(lines[:first_data]) or "\n", []),
            (src, "one data row", "refuse", "".join(lines[:first_data + 1]), []),
            (src, "binary garbage", "refuse", bytes(random.Random(5).randrange(256) for _ in range(3000)), []),
            (src, "text garbage", "refuse", "lorem ipsum dolor\nsit amet\n" * 20, []),
            (src, "a value of 1e300", "refuse", "".join(lines[:first_data + 5]) +
             _replace_value(lines[first_data + 5], src, "1e300") + "".join(lines[first_data + 6:]), []),
            (src, "a NaN value", "refuse", "".join(lines[:first_data + 5]) +
             _replace_value(lines[first_data + 5], src, "nan") + "".join(lines[first_data + 6:]), []),
            (src, "a word as a value", "refuse", "".join(lines[:first_data + 5]) +
             _replace_value(lines[first_data + 5], src, "oops") + "".join(lines[first_data + 6:]), []),
            (src, "3 MB field", "refuse", "".join(lines[:first_data + 5]) +
             _replace_value(lines[first_data + 5], src, "7" * (3 * 1024 * 1024)) + "".join(lines[first_data + 6:]),
             []),
            (src, "ragged row", "refuse", "".join(lines[:first_data + 5]) + lines[first_data + 5].rstrip("\n") +
             (",9\n" if src in ("csv", "imucal") else (" 9\n" if src == "imu_tk" else "\t9\n")) +
             "".join(lines[first_data + 6:]), []),
        ]
    muts += [
        ("imucal", "x_p rows read -1 g (mislabelled part)", "refuse",
         _imucal_rows(part_data={"x_p": (-2048, 0, 0)}), []),
        ("imucal", "unknown part q_p", "refuse", _imucal_rows().replace("y_a,", "q_p,"), []),
        ("csv", "+1 g rows labelled -Z up (mislabelled pose)", "refuse",
         _csv_rows(labels=(("+X up", (1, 0, 0)), ("-X up", (-1, 0, 0)), ("+Y up", (0, 1, 0)), ("-Y up", (0, -1, 0)),
                           ("+Z up", (0, 0, 1)), ("-Z up", (0, 0, 1)))), []),
        ("csv", "decreasing time stamps", "refuse", _csv_rows().replace("\n0.020,", "\n-5.0,"), []),
        ("csv", "counts without lsb_per_g", "refuse", _csv_rows(units="counts"), []),
        ("csv", "unknown units", "refuse", _csv_rows(units="furlongs"), []),
        ("csv", "no ax column", "refuse", _csv_rows().replace("t_s,ax,ay", "t_s,bx,ay"), []),
        ("csv", "--g 5", "refuse", _csv_rows(), ["--g", "5"]),
        ("csv", "--g nan", "refuse", _csv_rows(), ["--g", "nan"]),
        ("tofupilot", "--window-s -1", "refuse", _tofu_rows(), ["--window-s", "-1"]),
        ("tofupilot", "--window-s 0", "refuse", _tofu_rows(), ["--window-s", "0"]),
        ("tofupilot", "--window-s nan", "refuse", _tofu_rows(), ["--window-s", "nan"]),
        ("imu_tk", "decreasing time stamps", "refuse", _imu_tk_rows().replace("\n0.50000 ", "\n0.10000 "), []),
        ("csv", "--id ../escape", "refuse", _csv_rows(), ["--id", "../escape"]),
        ("csv", "--id a/b", "refuse", _csv_rows(), ["--id", "a/b"]),  # hint: "--id" or "id"
    ]
    if (DATASETS / "imu_tk-xsens" / "xsens_gyro.txt").exists():
        muts.append(("imu_tk", "gyro file imported as accelerometer data (then solved)", "gyro-as-accel",
                     (DATASETS / "imu_tk-xsens" / "xsens_gyro.txt").read_bytes(), []))
    cases = []
    for k, (src, name, expect, content, extra) in enumerate(muts):
        p = ws.path(f"import-{src}-{k}", ".txt" if src in ("imu_tk",) else ".csv")
        p.write_bytes(content if isinstance(content, bytes) else content.encode())
        out_dir = ws.root / "imports" / f"{k}"
        hint = (p.name,) if not extra else (p.name, extra[0], extra[0].lstrip("-") + ":")
        if expect == "gyro-as-accel":
            # refused at import (exit 2), or the solve that follows refuses: a calibration must not come out
            case = Case("import", f"{src}: {name}", ["import", "--from", src, p, "-o", out_dir, "--id", "g"], "valid",
                        hint=hint)
            case.script = (lambda c, out_dir=out_dir: gyro_as_accel(c, out_dir))
            cases.append(case)
            continue
        cases.append(Case("import", f"{src}: {name}", ["import", "--from", src, p, "-o", out_dir, *extra], expect,
                          hint=hint))
    p = ws.path("import-any", ".csv")
    p.write_text(_csv_rows())
    cases.append(Case("import", "--from bogus", ["import", "--from", "bogus", p], hint=("bogus", "--from")))
    cases.append(Case("import", "missing file", ["import", "--from", "csv", ws.root / "in" / "nope.csv"],
                      hint=("nope.csv",)))
    cases.append(Case("import", "a directory", ["import", "--from", "csv", ws.root / "in"], hint=("in",)))
    loop = ws.path("import-loop", ".csv")
    os.symlink(loop, loop)
    for src in ("csv", "imucal"):
        cases.append(Case("import", f"{src}: a symlink loop", ["import", "--from", src, loop, "-o",
                                                                ws.root / "imports" / "loop"], hint=(loop.name,)))
    return cases


def _replace_value(line: str, src: str, value: str) -> str:
    if src == "imu_tk":
        f = line.split()
        f[2] = value
        return " ".join(f) + "\n"
    sep = "\t" if src == "tofupilot" else ","
    f = line.rstrip("\n").split(sep)
    f[{"imucal": 3, "csv": 2, "tofupilot": 5}[src]] = value
    return sep.join(f) + "\n"


def gyro_as_accel(case: Case, out_dir: Path) -> None:
    """Import a gyroscope recording as accelerometer data: refused at import (exit 2, one line), or the magnitude
    solve that follows refuses; a calibration must not come out."""
    code, out, err, dt = runner.run_command(case, *case.args)
    if code == 2 and len(stderr_lines(err)) == 1 and "Traceback" not in err:
        case.result["category"] = "correct"
        return
    if code != 0:
        case.result["category"] = classify(Case(case.family, case.name, case.args, "refuse"), code, out, err)
        return
    code2, out2, err2, dt2 = runner.rig("solve", out_dir / "g", "--method", "magnitude", "-o", out_dir / "g.yaml")
    case.args = case.args + ["&&", "rig", "solve", out_dir / "g", "--method", "magnitude"]
    case.result.update(code=code2, first=first_line(err2), seconds=dt + dt2)
    case.result["category"] = classify(Case(case.family, case.name, case.args, "refuse"), code2, out2, err2)
    if case.result["category"] == "silent wrong result":
        try:
            acc = yaml.safe_load((out_dir / "g.yaml").read_text())["accelerometer"]
            case.result["why"] = f"solved: scale {acc['scale_counts_per_g'][0]:.3g} counts/g"
        except Exception:  # noqa: BLE001 - no readable calibration: the category says enough
            pass
