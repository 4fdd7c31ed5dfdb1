"""Attack class: damaged sessions given to ``rig solve/apply/evaluate/discover/replay/report`` and ``rig run
--resume``: corrupted copies of a real session's samples.csv and session.yaml (and seeded random cells), session
folders that are not one, a torn line in the step in progress, samples scaled by a factor (then solved), a
manifest whose ``samples_committed_bytes`` is 0 (then resumed), and a damaged ``rig discover`` document in the
session folder (then reported). The copies are unsealed (:func:`~.workspace.unsealed`: they stand for sessions of
an older rig or another tool, and attack the reader's own checks); ``sealed session`` changes sealed ones."""

from __future__ import annotations

import os
import random
import shutil
from pathlib import Path

import yaml

from . import runner
from .hostile import HOSTILE_BYTES, HOSTILE_YAML, bomb_yaml, csv_bytes, csv_rows, dump, set_path
from .runner import Case, classify
from .workspace import check_session, read_state

COMMANDS = ["solve", "apply", "evaluate", "discover", "replay"]


def samples_mutations(ws) -> list[tuple[str, str, bytes]]:
    """(name, expect, new samples.csv)."""
    header, rows = csv_rows(ws.samples)
    cols = header.split(",")
    ci = {c: i for i, c in enumerate(cols)}
    n = len(rows)
    out = []

    def cell(name, col, value, row=1234, expect="refuse"):
        r = [list(x) for x in rows]
        r[row][ci[col]] = value
        out.append((name, expect, csv_bytes(header, r)))

    cell("NaN count in ax", "ax", "nan")
    cell("empty az cell", "az", "")
    cell("non-integer count 12.5", "ay", "12.5")
    cell("count 40000000 (beyond the +-4 g range)", "ax", "40000000")
    cell("count 1e19", "az", "1e19")
    cell("count -1e19", "ay", "-1e19")
    cell("count 32768 (beyond int16)", "ax", "32768")
    cell("count is a word", "ax", "abc")
    cell("count infinity", "ax", "inf")
    cell("gyro count NaN", "wx", "nan")
    cell("gyro count 1.5", "wy", "1.5")
    cell("gyro count 1e19", "wz", "1e19")
    cell("step index 1.5", "step", "1.5", row=1500)
    cell("step index 0.9", "step", "0.9", row=500)
    cell("step index 99", "step", "99")
    cell("step index -1", "step", "-1")
    cell("step index NaN", "step", "nan")
    cell("step index 1e19", "step", "1e19")
    cell("t_s NaN", "t_s", "nan")
    cell("t_s empty", "t_s", "")
    cell("temp_c 1e300", "temp_c", "1e300", expect="refuse_or_warn")
    cell("3 MB cell", "ax", "1" * (3 * 1024 * 1024))
    # truncations
    out.append(("truncated to the header", "refuse", (header + "\n").encode()))
    out.append(("empty samples.csv", "refuse", b""))
    out.append(("truncated at 50% on a row boundary", "refuse_or_warn", csv_bytes(header, rows[: n // 2])))
    body = csv_bytes(header, rows)
    # a crash tears only the step in progress: a torn line inside a finished step is rows lost (refused)
    out.append(("torn last line inside a finished step (rows lost)", "refuse", body[:-7]))
    out.append(("last step missing (rows of step 5 gone)", "refuse_or_warn",
                csv_bytes(header, [r for r in rows if r[ci["step"]] != "5"])))
    out.append(("step 2 duplicated (rows appended twice)", "refuse_or_warn",
                csv_bytes(header, rows + [r for r in rows if r[ci["step"]] == "2"])))
    out.append(("step 0 rows relabelled as step 1", "refuse_or_warn",
                csv_bytes(header, [[*r[:1], "1" if r[1] == "0" else r[1], *r[2:]] for r in rows])))
    # columns
    swapped = [[*r[:2], r[ci["ay"]], r[ci["ax"]], *r[4:]] for r in rows]
    out.append(("ax and ay data swapped (header unchanged)", "refuse", csv_bytes(header, swapped)))
    swapped_xz = [[r[ci["az"]] if i == ci["ax"] else r[ci["ax"]] if i == ci["az"] else x for i, x in enumerate(r)]
                  for r in rows]
    out.append(("ax and az data swapped (header unchanged)", "refuse", csv_bytes(header, swapped_xz)))
    flipped = [[str(-int(x)) if i == ci["az"] else x for i, x in enumerate(r)] for r in rows]
    out.append(("az sign flipped (another sensor frame)", "refuse", csv_bytes(header, flipped)))
    perm = [cols.index(c) for c in ("az", "t_s", "ay", "step", "ax")] + [i for i, c in enumerate(cols)
                                                                        if c not in ("az", "t_s", "ay", "step", "ax")]
    out.append(("columns reordered consistently", "valid",
                csv_bytes(",".join(cols[i] for i in perm), [[r[i] for i in perm] for r in rows])))
    out.append(("extra non-numeric column", "valid", csv_bytes(header + ",note", [r + ["hello"] for r in rows])))
    out.append(("quoted fields", "valid", csv_bytes(header, [[f'"{x}"' for x in r] for r in rows])))
    out.append(("UTF-8 BOM", "valid", b"\xef\xbb\xbf" + body))
    out.append(("CRLF line endings", "valid", csv_bytes(header, rows, "\r\n")))
    out.append(("BOM and CRLF", "valid", b"\xef\xbb\xbf" + csv_bytes(header, rows, "\r\n")))
    out.append(("blank lines between rows", "valid", body.replace(b"\n", b"\n\n", 50)))
    out.append(("duplicate column name", "refuse", csv_bytes(header.replace("wx", "ax"), rows)))
    out.append(("missing az column", "refuse", csv_bytes(",".join(c for c in cols if c != "az"),
                                                          [[x for i, x in enumerate(r) if i != ci["az"]] for r in rows])))
    out.append(("empty column name", "refuse", csv_bytes(header.replace("wz", ""), rows)))
    out.append(("ragged row (extra field)", "refuse",
                csv_bytes(header, [r + ["7"] if i == 77 else r for i, r in enumerate(rows)])))
    out.append(("ragged row (missing field)", "refuse",
                csv_bytes(header, [r[:-1] if i == 77 else r for i, r in enumerate(rows)])))
    out.append(("binary garbage in the middle", "refuse", body[:50000] + bytes(range(256)) * 8 + body[50000:]))
    out.append(("all binary garbage", "refuse", bytes(random.Random(3).randrange(256) for _ in range(20000))))
    out.append(("unterminated quote", "refuse", body[:80000] + b'"' + body[80000:]))
    return out


def manifest_mutations(ws) -> list[tuple[str, str, str | bytes]]:
    """(name, expect, new session.yaml)."""
    out = []

    def mod(name, fn, expect="refuse"):
        doc = yaml.safe_load(ws.manifest_text)
        fn(doc)
        out.append((name, expect, dump(doc)))

    def setp(path, value):
        return lambda d: set_path(d, path, value)

    mod("format rig-session/2", setp("format", "rig-session/2"))
    mod("status bogus", setp("status", "finished-ish"))
    mod("step status bogus", setp("steps[0].status", "done"))
    mod("f_nominal a word", setp("steps[0].f_nominal", "up"))
    mod("f_nominal two numbers", setp("steps[0].f_nominal", [0, 0]))
    mod("f_nominal NaN", setp("steps[0].f_nominal", [float("nan"), 0, 1]))
    mod("f_nominal 5 g", setp("steps[0].f_nominal", [0, 0, 5]))
    mod("f_nominal of +Z and -Z swapped (contradicts the data, solve only)",
        lambda d: (set_path(d, "steps[0].f_nominal", [0, 0, -1]), set_path(d, "steps[2].f_nominal", [0, 0, 1])),
        expect="refuse_or_warn")
    mod("step index 1.5", setp("steps[1].index", 1.5))
    mod("step index 99", setp("steps[1].index", 99))
    mod("step index a word", setp("steps[1].index", "one"))
    mod("two steps with index 0", setp("steps[1].index", 0))
    mod("no steps", setp("steps", []))
    mod("last step removed", lambda d: d["steps"].pop())
    mod("steps a mapping", setp("steps", {"a": 1}))
    mod("accel_lsb_per_g 0", setp("rig.sensor.accel_lsb_per_g", 0))
    mod("accel_lsb_per_g negative", setp("rig.sensor.accel_lsb_per_g", -8192))
    mod("accel_lsb_per_g a word", setp("rig.sensor.accel_lsb_per_g", "lots"))
    mod("accel_lsb_per_g NaN", setp("rig.sensor.accel_lsb_per_g", float("nan")))
    mod("accel_lsb_per_g 1e300", setp("rig.sensor.accel_lsb_per_g", 1e300))
    mod("accel_range_g 3", setp("rig.sensor.accel_range_g", 3))
    mod("sample_rate_hz -100", setp("rig.sensor.sample_rate_hz", -100))
    mod("n_samples -5", setp("steps[0].stats.n_samples", -5))
    mod("n_samples 1.5", setp("steps[0].stats.n_samples", 1.5))
    mod("n_samples a word", setp("steps[0].stats.n_samples", "many"))
    mod("n_samples 999999 (contradicts samples.csv)", setp("steps[0].stats.n_samples", 999999),
        expect="refuse_or_warn")
    mod("id with ..", setp("id", "../../evil"))
    mod("id with a slash", setp("id", "a/b"))
    mod("samples_committed_bytes -1", setp("samples_committed_bytes", -1))
    mod("samples_committed_bytes a word", setp("samples_committed_bytes", "all"))
    mod("columns a word", setp("columns", "t_s ax"))
    mod("seed a word", setp("seed", "lucky"))
    mod("rig a list", setp("rig", [1, 2]))
    mod("rig.sensor missing", lambda d: d["rig"].pop("sensor"))
    mod("procedure.text a bomb", setp("procedure.text", bomb_yaml()), expect="refuse_or_warn")
    mod("has_temperature a word", setp("rig.sensor.has_temperature", "perhaps"))
    text = ws.manifest_text
    out.append(("duplicate key status", "refuse", text + "status: complete\n"))
    out.append(("CRLF line endings", "valid", text.replace("\n", "\r\n")))
    out.append(("UTF-8 BOM", "valid", b"\xef\xbb\xbf" + text.encode()))
    for name, fn in HOSTILE_YAML.items():
        if name in ("python object tag", "nesting 100 levels in a mapping"):
            continue
        out.append((name, "refuse", fn(text)))
    for name, fn in HOSTILE_BYTES.items():
        if name == "5 MiB file":  # a session manifest may be 16 MiB (a 10,000-step session's is 5-8 MB): 17 MiB
            out.append(("17 MiB file (over the manifest's 16 MiB)", "refuse",
                        text.encode() + b"# " + b"x" * (17 * 1024 * 1024) + b"\n"))
            out.append(("5 MiB comment (under the manifest's 16 MiB)", "valid", fn(text)))
            continue
        out.append((name, "refuse", fn(text)))
    return out


def session_case(ws, family, name, d, expect, cmd) -> Case:
    out_cal = d.parent / f"{d.name}-{cmd}.yaml"
    args = {"solve": ["solve", d, "-o", out_cal],
            "apply": ["apply", ws.calibration, d, "-o", d.parent / f"{d.name}-applied.csv"],
            "evaluate": ["evaluate", ws.calibration, d],
            "discover": ["discover", d],
            "replay": ["replay", d, "--out", d.parent / f"{d.name}-replayed"]}[cmd]
    check = None
    if expect in ("valid", "warn_close") and cmd == "solve":
        check = ws.same_as_ref(out_cal, sigmas=1.0 if expect == "warn_close" else 0.0)
    if expect == "warn_close":
        expect = "refuse_or_warn" if cmd != "solve" else "valid"
    return Case(family, f"{name} [{cmd}]", args, expect, hint=(d.name, "f_nominal"), check=check)


def cases(ws, rng: random.Random, quick: bool) -> list[Case]:
    out = []
    cmds = COMMANDS
    for k, (name, expect, data) in enumerate(samples_mutations(ws)):
        d = ws.session_copy(f"samples-{k}", samples=data)
        use = (["solve", cmds[1 + k % 4]] if k % 2 else [cmds[k % len(cmds)]]) if not quick else [cmds[k % len(cmds)]]
        if expect == "valid" or expect == "warn_close":
            use = ["solve", "apply"] if not quick else ["solve"]
        for cmd in use:
            if cmd == "replay" and expect != "refuse":
                continue
            out.append(session_case(ws, "samples.csv", name, d, expect, cmd))
    for k, (name, expect, data) in enumerate(manifest_mutations(ws)):
        d = ws.session_copy(f"manifest-{k}", manifest=data)
        use = [cmds[k % len(cmds)]]
        if expect == "valid" or "solve only" in name:
            use = ["solve"]
        for cmd in use:
            out.append(session_case(ws, "session.yaml", name, d, expect, cmd))
    out += random_cells(ws, rng, 12 if quick else 24)
    out += not_a_session(ws)
    d = torn_in_progress(ws)
    for cmd in ("solve", "apply"):
        out.append(session_case(ws, "samples.csv", "torn last line in the step in progress (aborted session)", d,
                                "warn", cmd))
    out += scaled_samples(ws)
    out += sealed_sessions(ws)
    out += resumes(ws)
    out += damaged_discover_documents(ws)
    return out


def random_cells(ws, rng: random.Random, n: int) -> list[Case]:
    """Hypothesis-style: seeded random cells of samples.csv replaced by tokens that must be refused."""
    header, rows = csv_rows(ws.samples)
    cols = header.split(",")
    tokens = {"ax": ["nan", "1.25", "4e7", "-4e7", "1e19", "x", "", "0x10", "inf"],
              "ay": ["nan", "0.5", "9e18", "", "--1"], "az": ["NaN", "2.5", "1e308", "one"],
              "step": ["0.5", "6", "-2", "nan", "", "2.000001", "1e3"], "t_s": ["nan", "", "t"],
              "wx": ["nan", "0.1", "1e19"], "wy": ["1.5"], "wz": ["-0.5", "nan"]}
    out = []
    for k in range(n):
        col = rng.choice(sorted(tokens))
        tok = rng.choice(tokens[col])
        row = rng.randrange(len(rows))
        r = [list(x) for x in rows]
        r[row][cols.index(col)] = tok
        d = ws.session_copy(f"random-{k}", samples=csv_bytes(header, r))
        out.append(session_case(ws, "samples.csv (random)", f"row {row + 2} {col}={tok!r}", d, "refuse",
                                rng.choice(COMMANDS[:4])))
    return out


def not_a_session(ws) -> list[Case]:
    out = []
    for name, d in (("missing directory", ws.root / "in" / "no-such-session"),
                    ("a file, not a directory", ws.path("session-file", ".txt"))):
        if name.startswith("a file"):
            d.write_text("hello\n")
        for cmd in (COMMANDS if name.startswith("missing") else ["solve", "replay"]):
            out.append(session_case(ws, "session dir", name, d, "refuse", cmd))
    d = ws.session_copy("no-manifest")
    (d / "session.yaml").unlink()
    for cmd in ("solve", "replay"):
        out.append(session_case(ws, "session dir", "session.yaml missing", d, "refuse", cmd))
    d = ws.session_copy("no-samples")
    (d / "samples.csv").unlink()
    for cmd in ("solve", "apply"):
        out.append(session_case(ws, "session dir", "samples.csv missing", d, "refuse", cmd))
    d = ws.session_copy("samples-loop")
    (d / "samples.csv").unlink()
    os.symlink(d / "samples.csv", d / "samples.csv")
    out.append(session_case(ws, "session dir", "samples.csv a symlink loop", d, "refuse", "solve"))
    loop = ws.path("session-loop")
    os.symlink(loop, loop)
    for cmd in COMMANDS:
        out.append(session_case(ws, "session dir", "session directory a symlink loop", loop, "refuse", cmd))
    d = ws.session_copy("manifest-loop")
    (d / "session.yaml").unlink()
    os.symlink(d / "session.yaml", d / "session.yaml")
    for cmd in ("solve", "replay"):
        out.append(session_case(ws, "session dir", "session.yaml a symlink loop", d, "refuse", cmd))
    return out


def torn_in_progress(ws) -> Path:
    """The session as a crash in its last step leaves it: status aborted, the last step pending (no stats),
    samples_committed_bytes at the end of the step before, and the last row torn."""
    doc = yaml.safe_load(ws.manifest_text)
    last = doc["steps"][-1]
    doc["status"] = "aborted"
    last["status"] = "pending"
    last.pop("stats", None)
    offset = 0
    for line in ws.samples.splitlines(keepends=True)[1:]:
        if line.split(b",")[1].strip() == str(last["index"]).encode():
            break
        offset += len(line)
    doc["samples_committed_bytes"] = len(ws.samples.splitlines(keepends=True)[0]) + offset
    return ws.session_copy("torn-in-progress", manifest=dump(doc), samples=ws.samples[:-7])


# ---------------------------------------------------------------------------------------- scaled, resumed, reported

def scaled_samples(ws) -> list[Case]:
    """Every accelerometer count multiplied by a factor (a range or sensitivity other than the manifest's), then
    solved: at rest the sensor reads ``factor`` g by the recorded sensitivity; a calibration that silently
    absorbs it into its scale factors is a wrong number."""
    header, rows = csv_rows(ws.samples)
    cols = header.split(",")
    acc = [cols.index(c) for c in ("ax", "ay", "az")]
    out = []
    for factor in (2.0, 0.5):
        scaled = [[str(int(round(int(x) * factor))) if i in acc else x for i, x in enumerate(r)] for r in rows]
        d = ws.session_copy(f"scaled-{factor:g}", samples=csv_bytes(header, scaled))
        for cmd in ("solve", "evaluate"):
            out.append(session_case(ws, "samples.csv (scaled)", f"accelerometer counts x{factor:g}", d,
                                    "refuse_or_warn", cmd))
    return out


def sealed_sessions(ws) -> list[Case]:
    """A sealed session whose samples.csv changed: harmlessly (CRLF line endings, the same values) or so that it
    still solves cleanly (every count x1.10): refused for the change, in one line naming the file."""
    header, rows = csv_rows(ws.samples)
    acc = [header.split(",").index(c) for c in ("ax", "ay", "az")]
    changed = {
        "CRLF line endings (the same values)": csv_bytes(header, rows, "\r\n"),
        "accelerometer counts x1.10 (solves cleanly)": csv_bytes(
            header, [[str(int(round(int(x) * 1.1))) if i in acc else x for i, x in enumerate(r)] for r in rows]),
    }
    out = []
    for k, (name, data) in enumerate(changed.items()):
        d = ws.session_copy(f"sealed-{k}", samples=data, sealed=True)
        for cmd in ("solve", "evaluate"):
            out.append(session_case(ws, "sealed session", name, d, "refuse", cmd))
    return out


def interrupted(ws, stem: str, committed) -> Path:
    """A copy of the clean session as an interrupted run leaves it (aborted, the last step pending) whose manifest
    says ``samples_committed_bytes: committed``; samples.csv keeps every row."""
    doc = yaml.safe_load(ws.manifest_text)
    doc["status"] = "aborted"
    doc["steps"][-1]["status"] = "pending"
    doc["steps"][-1].pop("stats", None)
    doc["samples_committed_bytes"] = committed
    return ws.session_copy(stem, manifest=dump(doc))


def resumes(ws) -> list[Case]:
    """``rig run --resume`` of a session whose manifest misstates what samples.csv holds: refused in one line
    with samples.csv untouched, or resumed with every committed step kept exactly once."""
    out = []
    for label, committed in (("0", 0), ("beyond the file", len(ws.samples) * 10)):
        d = interrupted(ws, f"resume-committed-{label.replace(' ', '_')}", committed)
        case = Case("resume", f"samples_committed_bytes {label}, then --resume",
                    ["run", "--resume", d, "--time-scale", "0", "--quiet"], "refuse", hint=(d.name, "samples"),
                    timeout=240)
        case.script = (lambda c, d=d: _resume_script(ws, c, d))
        out.append(case)
    return out


def _resume_script(ws, case: Case, d: Path) -> None:
    before_bytes = (d / "samples.csv").read_bytes()
    clean = read_state(ws.session)
    done = {s["index"] for s in clean["manifest"]["steps"][:-1]}
    before = {"manifest": clean["manifest"], "rows": {k: v for k, v in clean["rows"].items() if k in done}}
    code, out, err, _ = runner.run_command(case, *case.args)
    if code == 0 and "Traceback" not in err:
        cat, why = check_session(d, before, ws.ref)
        case.result.update(category=cat, why=why or "resumed: every committed step kept")
        return
    category = classify(case, code, out, err)
    if category != "traceback" and (d / "samples.csv").read_bytes() != before_bytes:
        category, case.result["why"] = "data lost", f"exit {code}, and samples.csv was changed (committed steps gone)"
    case.result["category"] = category


def damaged_discover_documents(ws) -> list[Case]:
    """A damaged ``rig discover`` document in the session folder: ``rig report`` still writes the report (exit 0)
    and names the document it left out."""
    good_format = '"format": "rig-discover/4"'
    docs = {
        "effects a string": '{' + good_format + ', "effects": "bias_tempco", "steps": []}',
        "a JSON list": '[{' + good_format + '}]',
        "truncated": '{' + good_format + ', "effects": [{"name": "bias_te',
        "nested 100000 deep": "[" * 100_000 + "]" * 100_000,
        "numbers as strings": '{' + good_format + ', "rms_before_g": "1e-4", "rms_after_g": "x", "effects": []}',
        "not UTF-8": b'{"format": "rig-discover/4", "note": "caf\xe9"}',
        "binary garbage": bytes(random.Random(9).randrange(256) for _ in range(4096)),
    }
    out = []
    for name, content in docs.items():
        d = ws.session_copy(f"discover-{name.replace(' ', '_')}")
        shutil.copy(ws.calibration, d / "calibration.yaml")
        (d / "discover.json").write_bytes(content if isinstance(content, bytes) else content.encode())
        html = ws.path(f"discover-{name.replace(' ', '_')}-report", ".html")

        def check(_out, html=html):
            try:
                text = html.read_text(encoding="utf-8", errors="replace")
            except OSError:
                return "no report written"
            return None if "discover.json" in text else "the report does not say the document was left out"

        out.append(Case("discover.json", f"{name} [report]", ["report", d, "-o", html, "--history", ws.history],
                        "valid", check=check, timeout=120))
    return out
