"""Attack class: command-line options (out-of-range, wrong types, contradictory combinations, unknown options,
a history option on a file that is not a database)."""

from __future__ import annotations

import hashlib

from .runner import SIX, Case


def cases(ws, rng, quick: bool) -> list[Case]:
    s, cal, out = ws.session, ws.calibration, ws.root / "opt-runs"
    run = ["run", SIX, "--out", out, "--quiet"]
    junk_db = ws.path("history-junk", ".sqlite")
    junk_db.write_bytes(b"this is not a database\n" * 10)
    junk_hash = hashlib.sha256(junk_db.read_bytes()).hexdigest()
    t = [
        ("bare rig", [], "refuse", ("rig --help",)),
        ("unknown command", ["frobnicate"], "refuse", ("frobnicate",)),
        ("--seed -1", run + ["--seed", "-1"], "refuse", ("--seed",)),
        ("--seed a word", run + ["--seed", "nine"], "refuse", ("--seed",)),
        ("--seed 2**64", run + ["--seed", str(2 ** 64)], "refuse", ("--seed",)),
        ("--seed 1.5", run + ["--seed", "1.5"], "refuse", ("--seed",)),
        ("--time-scale -1", run + ["--time-scale", "-1"], "refuse", ("--time-scale",)),
        ("--time-scale nan", run + ["--time-scale", "nan"], "refuse", ("--time-scale",)),
        ("--time-scale inf", run + ["--time-scale", "inf"], "refuse", ("--time-scale",)),
        ("--time-scale a word", run + ["--time-scale", "fast"], "refuse", ("--time-scale",)),
        ("--time-scale 1e300", run + ["--time-scale", "1e300"], "refuse", ("--time-scale",)),
        ("--rig missing file", run + ["--rig", ws.root / "nope.yaml"], "refuse", ("nope.yaml",)),
        ("--resume missing dir", ["run", "--resume", ws.root / "nope"], "refuse", ("nope",)),
        ("run without a procedure", ["run"], "refuse", ("procedure", "rig --help")),
        ("run unknown option", run + ["--turbo"], "refuse", ("--turbo",)),
        ("sim --count 0", ["sim", "--count", "0", "--once"], "refuse", ("--count",)),
        ("sim --count -3", ["sim", "--count", "-3", "--once"], "refuse", ("--count",)),
        ("sim --count 100000", ["sim", "--count", "100000", "--once"], "refuse", ("--count",)),
        ("sim --count a word", ["sim", "--count", "three", "--once"], "refuse", ("--count",)),
        ("sim --time-scale -1", ["sim", "--time-scale", "-1", "--once"], "refuse", ("--time-scale",)),
        ("sim --time-scale nan", ["sim", "--time-scale", "nan", "--once"], "refuse", ("--time-scale",)),
        ("sim --seed -1", ["sim", "--seed", "-1", "--once"], "refuse", ("--seed",)),
        ("sim --sensor BMI160", ["sim", "--sensor", "BMI160", "--once"], "refuse", ("--sensor", "BMI160")),
        ("solve --thermal 1 with --method magnitude", ["solve", s, "-o", ws.root / "o1.yaml", "--method", "magnitude",
                                                       "--thermal", "1"], "refuse", ("--thermal", "magnitude")),
        ("solve --thermal auto with --method magnitude", ["solve", s, "-o", ws.root / "o2.yaml", "--method",
                                                          "magnitude", "--thermal", "auto"], "refuse_or_warn",
         ("--thermal", "magnitude")),
        ("solve --model full --method flip", ["solve", s, "-o", ws.root / "o3.yaml", "--model", "full", "--method",
                                              "flip"], "refuse", ("full", "flip")),
        ("solve --model wobbly", ["solve", s, "--model", "wobbly"], "refuse", ("--model",)),
        ("solve --method magic", ["solve", s, "--method", "magic"], "refuse", ("--method",)),
        ("solve --thermal 9", ["solve", s, "-o", ws.root / "o4.yaml", "--thermal", "9"], "refuse", ("--thermal",)),
        ("solve --thermal -1", ["solve", s, "-o", ws.root / "o5.yaml", "--thermal", "-1"], "refuse", ("--thermal",)),
        ("solve --thermal hot", ["solve", s, "-o", ws.root / "o6.yaml", "--thermal", "hot"], "refuse", ("--thermal",)),
        ("solve --thermal 1 on a 0.0 C span", ["solve", s, "-o", ws.root / "o7.yaml", "--thermal", "1"], "refuse",
         ("thermal", "temperature")),
        ("solve unknown option", ["solve", s, "--fast"], "refuse", ("--fast",)),
        ("apply without -o", ["apply", cal, s], "refuse", ("-o", "rig --help")),
        ("apply unknown option", ["apply", cal, s, "-o", ws.root / "a.csv", "--gain", "2"], "refuse", ("--gain",)),
        ("evaluate unknown option", ["evaluate", cal, s, "--verbose"], "refuse", ("--verbose",)),
        ("discover --false-alarm 2", ["discover", s, "--false-alarm", "2"], "refuse", ("--false-alarm",)),
        ("discover --false-alarm -1", ["discover", s, "--false-alarm", "-1"], "refuse", ("--false-alarm",)),
        ("discover --false-alarm nan", ["discover", s, "--false-alarm", "nan"], "refuse", ("--false-alarm",)),
        ("discover --false-alarm a word", ["discover", s, "--false-alarm", "rare"], "refuse", ("--false-alarm",)),
        ("replay unknown option", ["replay", s, "--faster"], "refuse", ("--faster",)),
        ("export --to bogus", ["export", cal, "--to", "bogus"], "refuse", ("--to", "bogus")),
        ("export without --to", ["export", cal], "refuse", ("--to", "rig --help")),
        ("import without --from", ["import", cal], "refuse", ("--from", "rig --help")),
        ("import --g a word", ["import", "--from", "csv", cal, "--g", "heavy"], "refuse", ("--g",)),
        ("history --history on a non-database", ["history", "--history", junk_db], "refuse", (junk_db.name,)),
        ("history unknown sensor", ["history", "no-such-sensor", "--history", ws.root / "h.sqlite"], "refuse",
         ("no-such-sensor", "h.sqlite")),
        ("history --record a missing session", ["history", "--history", ws.root / "h2.sqlite", "--record",
                                                ws.root / "nope"], "refuse", ("nope",)),
        ("ports unknown option", ["ports", "--all"], "refuse", ("--all",)),
        ("--version", ["--version"], "valid", ()),
    ]
    cases = []
    for name, args, expect, hint in t:
        post = None
        if "non-database" in name:
            post = (lambda: "the non-database file was modified"
                    if hashlib.sha256(junk_db.read_bytes()).hexdigest() != junk_hash else None)
        check = None
        if name == "--version":
            check = lambda out: None if out.startswith("rig ") else f"stdout {out[:40]!r}"
        cases.append(Case("option", name, args, expect, hint=hint, post=post, check=check, timeout=40))
    return cases
