"""ETAs are wall-clock time (issue 33 item 4): at ``--time-scale K`` a run's remaining rig time takes 1/K of it
in wall time, so the console's plain progress says that, not the rig time ("run ETA 1m44s" for a 20 s run at
``--time-scale 5`` before). The rig is the in-process simulated rig at time scale 5 (a paced clock, as
``rig run --time-scale 5``) and the console is the one ``rig run`` uses, writing plain lines into a buffer."""

from __future__ import annotations

import io
import re
import time

from rig.cli.console import ConsoleUI, plain_progress_line
from rig.config.procedure import load_procedure_text
from rig.execution.operator import StepProgress

from rig.simulation.simrig import SimSettings, SimulatedRig
from rig.simulation.simulated import open_in_process_rig

from engine_rig import start

TIME_SCALE = 5.0
PROCEDURE = """format: rig-procedure/1
name: eta
sensor: {accel_range_g: 4, sample_rate_hz: 100}
dwell: {seconds: 2}
settle: {window_s: 0.3, threshold_g: 0.01, timeout_s: 20}
steps:
  - pose: "+Z up"
  - pose: "+X up"
  - pose: "-Z up"
"""


def _seconds(text: str) -> float:
    m = re.fullmatch(r"(?:(\d+)h)?(?:(\d+)m)?(?:(\d+)s)?", text)
    h, mnt, s = (int(x or 0) for x in m.groups())
    return 3600 * h + 60 * mnt + s


class Stamped(io.StringIO):
    """A text stream that notes when each line was written (wall clock)."""

    def __init__(self) -> None:
        super().__init__()
        self.lines: list[tuple[float, str]] = []

    def write(self, text: str) -> int:
        self.lines += [(time.monotonic(), x) for x in text.splitlines() if x]
        return super().write(text)


def test_the_run_eta_at_time_scale_5_is_wall_clock_time(tmp_path):
    rig = open_in_process_rig(SimulatedRig(SimSettings(time_scale=TIME_SCALE), seed=1), name="eta")
    try:
        proc = load_procedure_text(PROCEDURE, "eta.yaml")
        out = Stamped()
        eng, writer = start(proc, rig, tmp_path, ConsoleUI(out, interactive=False))
        eng.prepare(resuming=False, preflight=False)
        rig_began = rig.clock.now()
        eng.run()
        rig_s = rig.clock.now() - rig_began
        writer.close()
    finally:
        rig.close()
    etas = [(t, _seconds(m.group(1))) for t, line in out.lines if (m := re.search(r"run ETA (\S+)", line))]
    assert len(etas) >= 6, out.getvalue()
    # the first estimate is the whole run at the clock's pace: the rig time / 5 (it was the rig time)
    assert etas[0][1] <= rig_s / TIME_SCALE * 1.6 + 1 and etas[0][1] < rig_s / 2, (etas, rig_s)
    # later ones at the pace observed (a busy machine holds the simulated clock back, so a pace observed over a
    # few seconds is all a display can know); none is the rig time
    assert all(eta < rig_s / 1.5 for _, eta in etas), (etas, rig_s)


def test_virtual_time_shows_no_eta_and_hardware_pace_shows_rig_time():
    p = StepProgress(2, 6, "+X up", "capture", eta_s=100.0, run_eta_s=600.0, wall_per_rig_s=1 / TIME_SCALE)
    assert plain_progress_line(p).endswith("ETA 20s  run ETA 2m00s")
    virtual = StepProgress(2, 6, "+X up", "capture", eta_s=100.0, run_eta_s=600.0, wall_per_rig_s=None)
    assert "ETA" not in plain_progress_line(virtual)
    assert plain_progress_line(StepProgress(2, 6, "+X up", "capture", eta_s=9.0, run_eta_s=75.0)).endswith(
        "ETA 9s  run ETA 1m15s")
