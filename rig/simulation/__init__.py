"""The simulated rig and the replay rig: rig kinds ``sim`` and ``replay``.

Importing this package registers the rig file's ``sim:`` and ``faults:`` schemas (:mod:`rig.simulation.settings`)
and nothing more: a command that only reads a simulated session's rig file (``rig solve``: the uncertainty budget
reads its ``sim.geometry``) does not load the simulated world. The kinds are registered by the modules that open
them, :mod:`rig.simulation.simulated` (``sim``) and :mod:`rig.simulation.replay` (``replay``), when imported, and,
without the simulator, by :mod:`rig.workflow.kinds` (the composition root's part for the workflows) with openers
that import them when such a rig is opened.
"""

from rig.simulation import settings as _settings  # noqa: F401 - registers the sim: and faults: sections
