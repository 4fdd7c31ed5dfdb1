"""The simulated rig and the replay rig: rig kinds ``sim`` and ``replay``.

Importing this package registers both kinds with ``rig.devices.registry``; only composition roots
import it: the workflows, when a simulated or replay rig is opened (:mod:`rig.workflow.kinds`), ``rig
sim``, tests and benchmarks. Importing it loads the whole simulated world; the ``rig`` command never
imports it to start.
"""

from rig.simulation import settings as _settings  # noqa: F401 - registers the sim: and faults: sections
from rig.simulation import replay as _replay  # noqa: F401 - registers the "replay" kind
from rig.simulation import simulated as _simulated  # noqa: F401 - registers the "sim" kind
