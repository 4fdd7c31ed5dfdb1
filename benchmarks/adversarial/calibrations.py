"""Attack class: calibration files given to ``rig apply``, ``rig evaluate`` and ``rig export`` (wrong types and
shapes, contradictory matrices, a sensitivity of another range, hostile YAML, symlink loops, missing files)."""

from __future__ import annotations

import os

import yaml

from .hostile import HOSTILE_BYTES, HOSTILE_YAML, dump, set_path
from .runner import Case


def cases(ws, rng, quick: bool) -> list[Case]:
    base = yaml.safe_load(ws.calibration.read_text())
    text = ws.calibration.read_text()
    muts = []

    def mod(name, path, value, expect="refuse"):
        doc = yaml.safe_load(text)
        set_path(doc, path, value)
        muts.append((name, expect, dump(doc)))

    a = "accelerometer."
    mod("format rig-calibration/7", "format", "rig-calibration/7")
    mod("bias a word", a + "bias_counts", "abc")
    mod("bias element a word", a + "bias_counts[1]", "abc")
    mod("bias element a numeric string", a + "bias_counts[1]", "1.0")
    mod("bias two numbers", a + "bias_counts", [1.0, 2.0])
    mod("bias NaN", a + "bias_counts[0]", float("nan"))
    mod("bias infinity", a + "bias_counts[2]", float("inf"))
    mod("scale zero", a + "scale_counts_per_g", [0, 0, 0])
    mod("scale a word", a + "scale_counts_per_g[0]", "big")
    mod("scale 1e300", a + "scale_counts_per_g[0]", 1e300)
    mod("matrix 2x2", a + "matrix_counts_per_g", [[1, 0], [0, 1]])
    mod("matrix ragged", a + "matrix_counts_per_g[1]", [0, 1])
    mod("matrix a word inside", a + "matrix_counts_per_g[0][1]", "x")
    mod("matrix singular", a + "matrix_counts_per_g", [[0, 0, 0], [0, 0, 0], [0, 0, 0]])
    mod("matrix disagrees with scale", a + "matrix_counts_per_g[0][0]", 9000.0)
    mod("misalignment contradicts the matrix", a + "misalignment.alpha_yz", 0.5)
    mod("misalignment a word", a + "misalignment.alpha_zx", "tilted")
    mod("misalignment_unit furlongs", a + "misalignment_unit", "furlongs")
    mod("lsb_per_g 0", a + "lsb_per_g", 0)
    mod("lsb_per_g a word", a + "lsb_per_g", "x")
    mod("lsb_per_g 16384 (another range)", a + "lsb_per_g", 16384.0)
    mod("model a word", a + "model", "wobbly")
    mod("sigma bias shape", a + "sigma.bias_counts", [1.0])
    mod("sigma negative", a + "sigma.bias_counts", [-1.0, 0.3, 0.3])
    mod("temperature a word", a + "temperature", "hot")
    mod("accelerometer null", "accelerometer", None)
    mod("accelerometer a list", "accelerometer", [1, 2, 3])
    mod("sensor model ADXL345", "sensor.model", "ADXL345")
    mod("unknown top-level key", "flavour", "vanilla")
    muts.append(("duplicate key accelerometer", "refuse", text + "accelerometer: null\n"))
    muts.append(("truncated at 50%", "refuse", text[: len(text) // 2]))
    for name, fn in HOSTILE_YAML.items():
        if name not in ("python object tag", "nesting 100 levels in a mapping"):
            muts.append((name, "refuse", fn(text)))
    for name, fn in HOSTILE_BYTES.items():
        muts.append((name, "refuse", fn(text)))
    muts.append(("CRLF line endings", "valid", text.replace("\n", "\r\n")))
    cases = []
    for k, (name, expect, data) in enumerate(muts):
        p = ws.path(f"cal-{k}", ".yaml")
        p.write_bytes(data if isinstance(data, bytes) else data.encode())
        use = (("apply", "evaluate")[k % 2],)
        if name == "sensor model ADXL345" or name.startswith("lsb_per_g 16384"):
            use = ("evaluate",)
        for cmd in use:
            args = (["apply", p, ws.session, "-o", ws.root / "in" / f"{p.stem}-applied.csv"] if cmd == "apply"
                    else ["evaluate", p, ws.session])
            cases.append(Case("calibration", f"{name} [{cmd}]", args, expect, hint=(p.name,)))
    loop = ws.path("cal-loop", ".yaml")
    os.symlink(loop, loop)
    for cmd in ("apply", "evaluate", "export"):
        args = {"apply": ["apply", loop, ws.session, "-o", ws.root / "in" / "loop-applied.csv"],
                "evaluate": ["evaluate", loop, ws.session], "export": ["export", loop, "--to", "px4"]}[cmd]
        cases.append(Case("calibration", f"symlink loop [{cmd}]", args, hint=(loop.name,)))
    for cmd in ("apply", "evaluate", "export"):
        missing = ws.root / "in" / "no-such-calibration.yaml"
        args = {"apply": ["apply", missing, ws.session, "-o", ws.root / "x.csv"],
                "evaluate": ["evaluate", missing, ws.session],
                "export": ["export", missing, "--to", "px4"]}[cmd]
        cases.append(Case("calibration", f"missing file [{cmd}]", args, hint=(missing.name,)))
    bad = ws.path("cal-export", ".yaml")
    bad.write_text(dump({**base, "accelerometer": {**base["accelerometer"], "bias_counts": "abc"}}))
    for to in ("px4", "json"):
        cases.append(Case("calibration", f"bias a word [export --to {to}]", ["export", bad, "--to", to],
                          hint=(bad.name,)))
    return cases
