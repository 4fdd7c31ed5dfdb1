"""Compatibility: the names of the former ``rig.session.store``, now in :mod:`rig.session`.

Import from :mod:`rig.session` (``from rig.session import SessionWriter, load_session``); this module
goes once nothing imports it.
"""

from rig.session import (BASE_COLUMNS, FORMAT, OPTIONAL_COLUMNS, STATUSES, STEP_STATUSES, Session, SessionWriter,
                         load_session, mag_step_means, rate_step_means, read_samples, validate_session_id)

__all__ = ["BASE_COLUMNS", "FORMAT", "OPTIONAL_COLUMNS", "STATUSES", "STEP_STATUSES", "Session", "SessionWriter",
           "load_session", "mag_step_means", "rate_step_means", "read_samples", "validate_session_id"]
