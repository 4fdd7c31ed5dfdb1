"""A resume continues the same recording: the same rig file, controllers, sensor and simulated seed.

The manifest records what a session ran on; before a resume moves anything, the rig it would
resume on is compared with that record and every difference is named.
"""

from __future__ import annotations

from rig.devices.rig import Rig
from rig.planning.kinematics import STAGE_AXES
from rig.session import SessionManifest


def differences(recorded: SessionManifest, rig: Rig, rig_file_sha256: str | None) -> list[str]:
    """What differs between the recorded rig and ``rig`` (empty: the same rig), one phrase each."""
    out: list[str] = []
    if (recorded.seed is not None or rig.seed is not None) and recorded.seed != rig.seed:
        out.append(f"simulated sensor seed {rig.seed} (recorded {recorded.seed})")
    was = recorded.rig.rig_file_sha256
    if was is not None and rig_file_sha256 is not None and was != rig_file_sha256:
        out.append(f"rig file {rig.rig_file} has other contents than the one recorded "
                   f"(sha256 {rig_file_sha256[:12]}, recorded {was[:12]})")
    now = rig.describe()
    axes = (recorded.rig.turntable.axes or {}) if recorded.rig.turntable else {}
    for name in STAGE_AXES:
        if name in axes and axes[name].serial is not None and axes[name].serial != now["turntable"]["axes"][name]["serial"]:
            out.append(f"{name} controller serial {now['turntable']['axes'][name]['serial']} "
                       f"(recorded {axes[name].serial})")
    sensor = recorded.rig.sensor
    for key in ("model", "address"):
        if getattr(sensor, key) is not None and getattr(sensor, key) != now["sensor"][key]:
            out.append(f"sensor {key} {now['sensor'][key]} (recorded {getattr(sensor, key)})")
    return out
