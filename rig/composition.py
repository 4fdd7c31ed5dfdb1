"""The composition root: where the simulator is wired into the runtime (docs/architecture.md).

Runtime rig code (``rig.config`` ... ``rig.lab``) never imports :mod:`rig.simulation`: the import contracts
in pyproject.toml forbid it, and no module imports one of ours by a name string, so the contracts see
every edge. What the simulator provides reaches the runtime through registries the lower layers hold,
filled from above:

- the rig file's ``sim:`` and ``faults:`` sections (:mod:`rig.config.sections`): :func:`wire` registers
  :func:`simulation_settings` as their provider, a function whose body imports the simulator's schemas (an
  ordinary import statement, which import-linter sees). It runs the first time a rig file has such a
  section, so a program that reads only hardware rig files, ``rig --help`` and ``rig solve`` never load
  the simulator (about 1 s).
- the ``sim`` and ``replay`` rig kinds (:mod:`rig.devices.registry`): registered by
  :mod:`rig.workflow.kinds`, the workflows' part of this root (the workflows are the only code that opens
  a rig by kind), with openers that import the simulator when such a rig is opened. They are not
  registered here because registering them imports ``rig.devices`` and the workflows' openers, which a
  command that opens no rig (``rig solve``) must not pay for.

Where :func:`wire` is called (it is idempotent):

- :func:`rig.cli.main.main`, once a command is parsed (not for ``rig --help``/``--version``), before the
  command runs: every command reads rig files with the same answer (``rig discover --twin``, ``rig
  compare``, ``rig run``);
- :mod:`rig.workflow.kinds` when it is imported, i.e. by :mod:`rig.workflow.run` and
  :mod:`rig.workflow.replay`: the Python API (``run_procedure``, ``replay_session``) is wired without the
  command line;
- a program that reads rig files through ``rig.config`` alone (a script, the test suite: tests/conftest.py
  imports :mod:`rig.workflow.kinds`) calls it itself; unwired, it refuses a ``sim:`` or ``faults:`` section
  (one located line), whatever it imported before.
"""

from __future__ import annotations

from types import ModuleType

from rig.config.sections import register_provider

#: the rig file's sections the simulator owns (their schemas: rig/simulation/settings.py)
SIMULATOR_SECTIONS = ("sim", "faults")


def simulation_settings() -> ModuleType:
    """The provider of the ``sim:`` and ``faults:`` schemas: :mod:`rig.simulation.settings`, whose import
    registers both with :mod:`rig.config.sections` (and loads the simulated world with it)."""
    from rig.simulation import settings  # deferred: the simulator loads when a rig file has its section
    return settings


def wire() -> None:
    """Register the simulator's providers with the registries below (see the module docstring)."""
    for name in SIMULATOR_SECTIONS:
        register_provider(name, simulation_settings)
