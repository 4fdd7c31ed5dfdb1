"""The screenshot of a rendered ``rig report`` kept for review in ``docs/images/report.png``.

    python benchmarks/report_screenshot.py [OUT.png]

Runs ``procedures/thermal.yaml`` with a few acceptance limits added (``ACCEPT``) on the simulated
rig (seed 3, a history database of its own), saves ``rig discover --json`` into the session, writes
its report and renders it in headless Chromium (the Debian package ``chromium``) at 1280 x 2400.
Everything happens in a temporary folder; only the PNG is kept. Exit 1 without Chromium.
"""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from rig.cli import main  # noqa: E402
from rig.lab.report import write_report  # noqa: E402

WINDOW = "1280,2400"
#: acceptance limits appended to the shipped thermal procedure (docs/acceptance.md)
ACCEPT = """
accept:
  ranges:
    accel.scale_*: [7900, 8500]
  max_chi2_per_dof: 5
  max_attitude_error_deg: 0.05
"""


def screenshot(page: Path, out: Path, profile: Path) -> None:
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        raise SystemExit("chromium not found (Debian: apt-get install chromium)")
    subprocess.run([exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                    "--disable-background-networking", "--disable-component-update", "--disable-sync",
                    f"--user-data-dir={profile}", "--hide-scrollbars", f"--screenshot={out}",
                    f"--window-size={WINDOW}", page.resolve().as_uri()],
                   check=True, capture_output=True, timeout=180)


def run(out: Path) -> Path:
    with tempfile.TemporaryDirectory(prefix="rig-report-shot-") as tmp:
        root = Path(tmp)
        os.environ["RIG_HISTORY"] = str(root / "history.sqlite")
        procedure = root / "thermal.yaml"
        procedure.write_text((REPO / "procedures" / "thermal.yaml").read_text() + ACCEPT)
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            if main(["run", str(procedure), "--seed", "3", "--time-scale", "0", "--out", str(root / "run"), "--quiet"]):
                raise SystemExit("rig run failed (or the acceptance limits failed)")
        session = next((root / "run").iterdir())
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            if main(["discover", str(session), "--json"]):
                raise SystemExit("rig discover failed")
        (session / "discover.json").write_text(buf.getvalue())
        page = write_report(session, history_db=root / "history.sqlite")
        out.parent.mkdir(parents=True, exist_ok=True)
        screenshot(page, out, root / "chromium-profile")
    return out


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "docs" / "images" / "report.png"
    print(f"screenshot: {run(target)}")
