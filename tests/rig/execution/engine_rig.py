"""What the engine tests share: in-process simulated rigs in virtual time, closed after the test, and
an engine started on a fresh session for a procedure."""

from __future__ import annotations

import pytest

from rig.execution.engine import Engine
from rig.execution.operator import SilentOperator
from rig.session import SessionWriter
from rig.simulation.simrig import SimSettings, SimulatedRig
from rig.simulation.simulated import open_in_process_rig
from rig.workflow.lifecycle import session_columns


@pytest.fixture
def make_rig(request):
    """``make(seed=1, model="MPU-9150", **SimSettings fields)``: an in-process simulated rig in virtual time."""
    rigs = []

    def make(seed: int = 1, model: str = "MPU-9150", **settings):
        sim = SimulatedRig(SimSettings(time_scale=0, **settings), seed=seed, sensor_model=model)
        rig = open_in_process_rig(sim, name=f"{request.node.name}-{len(rigs)}")
        rigs.append(rig)
        return rig

    yield make
    for rig in rigs:
        rig.close()


def start(proc, rig, tmp_path, operator=None, *, text: str | None = None, **kw) -> tuple[Engine, SessionWriter]:
    """An engine for ``proc`` on ``rig`` recording into a new session under ``tmp_path``; the manifest
    records ``text`` as the procedure's text (default: the procedure's own)."""
    rig.sensor.configure(proc.sensor_settings())
    manifest = {"procedure": {"name": proc.name, "text": proc.text if text is None else text, "file": None},
                "rig": rig.describe(), "software": {"name": "test"},
                "steps": [s.to_manifest() for s in proc.expanded_steps()]}
    writer = SessionWriter.create(tmp_path, "unit", manifest, columns=session_columns(proc, rig))
    return Engine(proc, rig, writer, operator or SilentOperator(), **kw), writer
