"""The lab around the rig: the calibration history (``history.py``, ``drift.py``) and exports (``exports.py``).

A layer between ``rig.workflow`` and ``rig.analysis`` (docs/architecture.md): it reads sessions and
calibration files, never drives a rig and never imports a simulator.
"""

from rig.lab.drift import (TABLE_WIDTH, CalibrationRecord, drift, format_history, history_document, list_sensors, plot_history,
                           resolve_sensor, sensor_history)
from rig.lab.exports import TARGETS, Export, export_calibration, parse_param_file
from rig.lab.history import (DEFAULT_PATH, ENV_VAR, SCHEMA_VERSION, History, HistoryCorrupt, HistoryError, HistoryLocked,
                             default_path, open_history, record_calibration, store_calibration)

__all__ = ["TABLE_WIDTH", "CalibrationRecord", "drift", "format_history", "history_document", "list_sensors", "plot_history",
           "resolve_sensor", "sensor_history", "TARGETS", "Export", "export_calibration", "parse_param_file",
           "DEFAULT_PATH", "ENV_VAR", "SCHEMA_VERSION", "History", "HistoryCorrupt", "HistoryError", "HistoryLocked",
           "default_path", "open_history", "record_calibration", "store_calibration"]
