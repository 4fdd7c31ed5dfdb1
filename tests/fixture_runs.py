"""What the fixture tests share: the simulated fixture with its first slots only, and an operator who presses Ctrl-C
at a given capture."""

from __future__ import annotations

from pathlib import Path

import yaml

from conftest import RIGS
from rig.execution.operator import SilentOperator


def fixture_rig_file(folder: Path, n_slots: int) -> Path:
    """``rigs/sim-fixture.yaml`` with its first ``n_slots`` slots, in virtual time, written into ``folder``."""
    doc = yaml.safe_load((RIGS / "sim-fixture.yaml").read_text())
    doc["fixture"]["slots"] = doc["fixture"]["slots"][:n_slots]
    doc["sim"]["time_scale"] = 0
    path = Path(folder) / f"fixture-{n_slots}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


class CtrlCAt(SilentOperator):
    """An operator who presses Ctrl-C when the capture of step ``index`` (from 0) starts."""

    def __init__(self, index: int) -> None:
        super().__init__()
        self.index = index

    def progress(self, progress) -> None:
        if progress.index == self.index and progress.phase == "capture":
            raise KeyboardInterrupt
