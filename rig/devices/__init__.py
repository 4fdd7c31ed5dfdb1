"""Devices: the :class:`Rig` the engine drives and the registry that opens one of any kind."""

from rig.devices import hardware as _hardware  # noqa: F401 - registers the "hardware" kind
from rig.devices.registry import RIG_KINDS, open_rig, open_rig_file, register_rig_kind
from rig.devices.rig import Axis, Rig, describe_sensor

__all__ = ["Axis", "Rig", "RIG_KINDS", "describe_sensor", "open_rig", "open_rig_file", "register_rig_kind"]
