"""The simulated rig and the replay rig: rig kinds ``sim`` and ``replay``.

Importing this package registers both kinds with ``rig.devices.registry``; only composition roots
(the ``rig`` command, the workflows, tests and benchmarks) import it.
"""

from rig.simulation import settings as _settings  # noqa: F401 - registers the sim: and faults: sections
from rig.simulation import replay as _replay  # noqa: F401 - registers the "replay" kind
from rig.simulation import simulated as _simulated  # noqa: F401 - registers the "sim" kind
