"""Which code opens which kind of rig: one table, filled by the packages that provide a kind.

``hardware`` is provided here (:mod:`rig.devices.hardware`); the simulated rig (``sim``) and the
replay of a recorded session (``replay``) register themselves when :mod:`rig.simulation` is
imported, which only the composition roots do (the workflows, ``rig sim``, tests). The workflows
register both kinds ahead (:mod:`rig.workflow.kinds`) with openers that import the simulator when such
a rig is opened, so a command that opens none never loads it. Runtime code asks for a kind by name and
never imports a simulator.
"""

from __future__ import annotations

from typing import Callable

from rig.devices.rig import Rig
from rig.errors import RigInputError

#: kind -> opener(spec, **options) -> Rig
RIG_KINDS: dict[str, Callable[..., Rig]] = {}


def register_rig_kind(kind: str, opener: Callable[..., Rig]) -> None:
    """Make ``open_rig(kind, ...)`` call ``opener``."""
    RIG_KINDS[kind] = opener


def open_rig(kind: str, spec, **options) -> Rig:
    """Open a rig of ``kind`` from ``spec`` (a loaded rig file; a session for ``replay``).

    Raises
    ------
    RigInputError
        No provider of that kind is loaded in this program.
    """
    opener = RIG_KINDS.get(kind)
    if opener is None:
        where = getattr(spec, "path", None)
        raise RigInputError(where, None, "kind", f"no rig of kind {kind!r} can be opened here "
                            f"(known: {', '.join(sorted(RIG_KINDS)) or 'none'})")
    return opener(spec, **options)


def open_rig_file(rig_file, *, seed: int | None = None, time_scale: float | None = None,
                  clock: str | None = None) -> Rig:
    """Open the rig a loaded rig file describes (its ``kind`` chooses the opener). ``time_scale`` and
    ``clock`` ("elastic" or "strict", docs/simulated-rig.md) override a simulated rig's own."""
    return open_rig(rig_file.kind, rig_file, seed=seed, time_scale=time_scale, clock=clock)
