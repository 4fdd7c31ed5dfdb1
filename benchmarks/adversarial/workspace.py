"""The campaign's workspace: a clean session and calibration of the simulated rig, the place for the mutated
copies, and what a session recorded (or resumed) correctly must be (:func:`check_session`)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import yaml

from . import runner
from rig.session import SessionManifest

from .runner import SEED_SENSOR, SIX, stderr_lines


def unsealed(text: str) -> str:
    """session.yaml's text without its seal (``rig run`` appends it last, docs/session-format.md "Seal"): the
    session as an older rig, another tool or a hand writes it. A sealed session whose files change is refused
    for that alone; the mutated copies attack the reader's own checks, so they are unsealed (as tests/conftest.py
    ``unseal`` does), and the family ``sealed session`` attacks the seal."""
    at = text.find("\nseal:\n")
    return text[:at + 1] if at >= 0 else text


class Workspace:
    """A clean session and calibration of the simulated rig, and a place for the mutated copies; ``history``: a
    history database holding the clean session's calibration (sensor ``sim-seed-9``). ``manifest_text`` and
    ``manifest``: the clean session.yaml without its seal (``sealed_manifest_text``: as recorded)."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.n = 0
        code, out, err, _ = runner.rig("run", SIX, "--out", root / "clean", "--seed", SEED_SENSOR, "--time-scale",
                                       "0", "--quiet", timeout=300)
        if code != 0:
            raise SystemExit(f"the clean run failed (exit {code}): {err.strip()[-500:]}")
        self.session = next((root / "clean").iterdir())
        self.calibration = self.session / "calibration.yaml"
        code, out, err, _ = runner.rig("solve", self.session, "-o", root / "ref.yaml", timeout=300)
        if code != 0:
            raise SystemExit(f"the clean solve failed (exit {code}): {err.strip()[-500:]}")
        self.ref = yaml.safe_load((root / "ref.yaml").read_text())["accelerometer"]
        self.sealed_manifest_text = (self.session / "session.yaml").read_text()
        self.manifest_text = unsealed(self.sealed_manifest_text)
        self.manifest = yaml.safe_load(self.manifest_text)
        self.samples = (self.session / "samples.csv").read_bytes()
        self.history = root / "lab-history.sqlite"
        code, out, err, _ = runner.rig("history", "--record", self.session, "--history", self.history, timeout=120)
        if code != 0:
            raise SystemExit(f"recording the clean calibration failed (exit {code}): {err.strip()[-500:]}")

    def path(self, stem: str, suffix: str = "") -> Path:
        self.n += 1
        p = self.root / "in" / f"{self.n:04d}-{stem}{suffix}"
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def session_copy(self, stem: str, manifest: str | bytes | None = None, samples: bytes | None = None,
                     sealed: bool = False) -> Path:
        """A copy of the clean session (no calibration, no lock): unsealed unless ``sealed``; ``manifest``,
        ``samples``: the new session.yaml, samples.csv."""
        d = self.path(stem)
        shutil.copytree(self.session, d, ignore=shutil.ignore_patterns("session.lock", "calibration.yaml"))
        if manifest is None and not sealed:
            manifest = self.manifest_text
        if manifest is not None:
            (d / "session.yaml").write_bytes(manifest.encode() if isinstance(manifest, str) else manifest)
        if samples is not None:
            (d / "samples.csv").write_bytes(samples)
        return d

    def same_as_ref(self, cal_path: Path, sigmas: float = 0.0):
        """A check: the solved calibration equals the clean one (exactly, or within ``sigmas``)."""
        def check(_out: str) -> str | None:
            try:
                acc = yaml.safe_load(Path(cal_path).read_text())["accelerometer"]
            except Exception as exc:  # noqa: BLE001
                return f"no calibration written ({exc})"
            for key in ("bias_counts", "scale_counts_per_g"):
                for a, b, s in zip(acc[key], self.ref[key], self.ref["sigma"][key]):
                    tol = sigmas * s if sigmas else 1e-9 * max(1.0, abs(b))
                    if not abs(a - b) <= tol:
                        return f"{key} {a:.6g} != clean {b:.6g}"
            return None
        return check


def read_state(d: Path) -> dict:
    """Manifest steps and the rows of samples.csv per step (as raw lines), for data-loss and duplicate checks."""
    m = SessionManifest.load(d)[1]  # the steps journal of a killed run folded in, as every reader does
    data = (d / "samples.csv").read_bytes()
    committed = m.get("samples_committed_bytes") or 0
    lines = data[:committed].decode().splitlines() if committed else data.decode().splitlines()
    header = lines[0].split(",") if lines else []
    rows: dict[int, list[str]] = {}
    order: list[int] = []
    for line in lines[1:]:
        if not line.strip():
            continue
        step = int(float(line.split(",")[header.index("step")]))
        if not order or order[-1] != step:
            order.append(step)
        rows.setdefault(step, []).append(line)
    return {"manifest": m, "rows": rows, "order": order, "header": header}


def check_session(d: Path, before: dict | None, ref: dict) -> tuple[str, str]:
    """(category, why) of a resumed session: data lost, a wrong/duplicated step, or correct. Steps are named as
    messages name them: ``step N`` counted from 1 (index N-1 in samples.csv)."""
    st = read_state(d)
    m = st["manifest"]
    if before is not None:
        for step, lines in before["rows"].items():
            prev = next(s for s in before["manifest"]["steps"] if s["index"] == step)
            if prev["status"] != "complete":
                continue
            if st["rows"].get(step) != lines:
                return "data lost", f"committed step {step + 1} changed or lost by the resume"
    if m["status"] != "complete":
        return "data lost", f"session status {m['status']} after the resume"
    ti = st["header"].index("t_s")
    for s in m["steps"]:
        if s["status"] != "complete":
            return "data lost", f"step {s['index'] + 1} {s['status']}"
        rows = st["rows"].get(s["index"], [])
        if len(rows) != s["stats"]["n_samples"]:
            return ("silent wrong result",
                    f"step {s['index'] + 1}: {len(rows)} rows, manifest n_samples {s['stats']['n_samples']}")
        t = [float(r.split(",")[ti]) for r in rows]
        if any(b <= a for a, b in zip(t, t[1:])):
            return "silent wrong result", f"step {s['index'] + 1}: t_s not increasing"
    if len(st["order"]) != len(set(st["order"])):
        return "silent wrong result", f"steps interleaved or duplicated in samples.csv (indices {st['order']})"
    size = (d / "samples.csv").stat().st_size
    if m.get("samples_committed_bytes") != size:
        return "silent wrong result", f"samples.csv has {size} bytes, manifest says {m.get('samples_committed_bytes')}"
    code, out, err, _ = runner.rig("solve", d, "-o", d.parent / f"{d.name}-check.yaml", timeout=120)
    if code != 0:
        return "wrong exit code", f"solve of the resumed session: exit {code}: {(stderr_lines(err) or [''])[0]}"
    acc = yaml.safe_load((d.parent / f"{d.name}-check.yaml").read_text())["accelerometer"]
    for key in ("bias_counts", "scale_counts_per_g"):
        for a, b, sa, sb in zip(acc[key], ref[key], acc["sigma"][key], ref["sigma"][key]):
            if abs(a - b) > 5 * math.hypot(sa, sb):
                return "silent wrong result", f"{key} {a:.2f} vs uninterrupted {b:.2f} (> 5 sigma)"
    return "correct", ""
