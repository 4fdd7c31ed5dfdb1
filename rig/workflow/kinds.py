"""The simulated (``sim``) and replayed (``replay``) rig kinds, registered without loading the simulator:
the workflows' part of the composition root (:mod:`rig.composition`).

:mod:`rig.simulation` registers both kinds with :mod:`rig.devices.registry` when it is imported, but
importing it costs what a simulated world needs (the world model, noise synthesis with scipy.signal,
the emulated controllers). The workflows, which open rigs by kind, import this module instead: it
registers both kinds with openers that import :mod:`rig.simulation` when such a rig is opened (deferred
imports, docs/architecture.md), so a hardware run or a command that opens no rig never loads the
simulator. A kind whose opener is registered already (the simulator was imported) keeps it.

Importing this module also wires the rest of the simulator in (:func:`rig.composition.wire`: the rig
file's ``sim:`` and ``faults:`` sections), so the workflows' Python API (``rig.workflow.run.run_procedure``,
``rig.workflow.replay.replay_session``) loads a simulated rig file without the command line.
"""

from __future__ import annotations

from typing import Callable

from rig.composition import wire
from rig.devices.registry import RIG_KINDS, register_rig_kind
from rig.devices.rig import Rig


def open_simulated(rig_file, **options) -> Rig:
    """Open the simulated rig a ``kind: sim`` rig file describes (imports the simulator now)."""
    from rig.simulation.simulated import open_simulated_rig  # deferred: only when a simulated rig is opened
    return open_simulated_rig(rig_file, **options)


def open_replay(session, **options) -> Rig:
    """Open the replay rig of a loaded session (imports the simulator now)."""
    from rig.simulation.replay import open_replay_rig  # deferred: only when a session is replayed
    return open_replay_rig(session, **options)


#: kind -> the opener registered here
OPENERS: dict[str, Callable[..., Rig]] = {"sim": open_simulated, "replay": open_replay}

for _kind, _opener in OPENERS.items():
    if _kind not in RIG_KINDS:
        register_rig_kind(_kind, _opener)
wire()
