"""Sessions (``rig-session/1``): the recording on disk. See docs/session-format.md.

- :mod:`rig.session.manifest`: ``session.yaml`` as a typed model (:class:`SessionManifest`);
- :mod:`rig.session.writer`: :class:`SessionWriter` (create, resume, append, complete steps, events);
- :mod:`rig.session.reader`: :func:`load_session`, :func:`read_samples`, :class:`Session`;
- :mod:`rig.session.adapter`: the one session -> calib adapter (:func:`step_means`,
  :func:`rate_step_means`, :func:`mag_step_means`).
"""

from rig.session.adapter import mag_step_means, rate_step_means, step_means
from rig.session.manifest import (BASE_COLUMNS, FORMAT, MAG_COUNTS_PER_UT, OPTIONAL_COLUMNS, STATUSES, STEP_STATUSES, AxisInfo,
                                  ImportInfo, MagnetometerInfo, ProcedureInfo, RigInfo, SensorInfo, SessionManifest,
                                  SiteInfo, SoftwareInfo, StepRecord, StepStats, TurntableInfo, utc_now)
from rig.session.reader import Session, load_session, read_samples
from rig.session.writer import SessionWriter, validate_session_id

__all__ = [
    "BASE_COLUMNS", "FORMAT", "MAG_COUNTS_PER_UT", "OPTIONAL_COLUMNS", "STATUSES", "STEP_STATUSES",
    "AxisInfo", "ImportInfo", "MagnetometerInfo", "ProcedureInfo", "RigInfo", "SensorInfo", "SessionManifest",
    "SiteInfo", "SoftwareInfo", "StepRecord", "StepStats", "TurntableInfo", "utc_now",
    "Session", "load_session", "read_samples", "SessionWriter", "validate_session_id",
    "step_means", "rate_step_means", "mag_step_means",
]
