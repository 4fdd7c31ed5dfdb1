"""Are two sessions of one unit? What ``rig compare`` says first when they are not (issue 33 item 3).

Two sessions of two different units differ by the units' own errors (bias, scale, misalignment), so a
disagreement between them says nothing about either: no shock, no re-mount. The evidence, from the manifests
only, by the sensor key the history files calibrations under (:mod:`rig.analysis.sensor_key`):

| evidence | verdict |
|---|---|
| the sensor models differ | different units |
| both sessions name a serial (or fixture id) and they differ | different units |
| one session was recorded on the digital twin of the other (its recorded rig file is ``twin-<the other's id>``, unchanged since: same sha256) | the same unit by construction (said) |
| a replay, or a serial on one side only | cannot tell: nothing said |
| otherwise the keys differ (another simulated seed: another drawn sensor; another I2C address or identity) | different units |
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

from rig.analysis.sensor_key import get_path, sensor_identity

_TWIN_NAME = re.compile(r"^name:\s*['\"]?twin-(?P<of>[^'\"\n]+?)['\"]?\s*$", re.MULTILINE)


@dataclass(frozen=True)
class Units:
    """The two sessions' sensor keys; ``different``: two different units, ``why`` the evidence; ``twin``: a note
    when one session was recorded on the other's digital twin."""

    a: str
    b: str
    different: bool = False
    why: str = ""
    twin: str = ""

    def to_json(self) -> dict:
        return {"a": self.a, "b": self.b, "different": self.different, "why": self.why or None,
                "twin": self.twin or None}


def _twin_of(manifest: dict) -> str | None:
    """The session id whose twin this session was recorded on: its rig file, as recorded (same sha256), is named
    ``twin-<id>`` (``rig discover --twin``). None otherwise or when the file is gone or changed."""
    path, sha = get_path(manifest, "rig", "rig_file"), get_path(manifest, "rig", "rig_file_sha256")
    if not path or not sha:
        return None
    try:
        raw = Path(path).read_bytes()
    except OSError:
        return None
    if hashlib.sha256(raw).hexdigest() != sha:
        return None
    m = _TWIN_NAME.search(raw.decode("utf-8", "replace"))
    return m.group("of").strip() if m else None


def _is_replay(manifest: dict) -> bool:
    return str(get_path(manifest, "rig", "turntable", "kind") or "").startswith("replay")


def units_of(manifest_a: dict, manifest_b: dict) -> Units:
    """What the manifests (plain mappings) say about the units of two sessions."""
    ia, ib = sensor_identity(manifest_a, None), sensor_identity(manifest_b, None)
    units = Units(ia["key"], ib["key"])
    if ia["model"] != ib["model"]:
        return Units(units.a, units.b, True, f"sensor models {ia['model']} and {ib['model']}")
    if ia["serial"] is not None and ib["serial"] is not None:
        if ia["serial"] == ib["serial"]:
            return units
        return Units(units.a, units.b, True, f"serials {ia['serial']} and {ib['serial']}")
    for m, other, name in ((manifest_b, manifest_a, "B"), (manifest_a, manifest_b, "A")):
        of = _twin_of(m)
        if of is not None and other.get("id") and str(other["id"]).startswith(of):
            return Units(units.a, units.b, twin=f"{name} was recorded on the digital twin of "
                                                  f"{'A' if name == 'B' else 'B'}: the same unit, simulated")
    if _is_replay(manifest_a) or _is_replay(manifest_b) or (ia["serial"] is None) != (ib["serial"] is None):
        return units
    if units.a == units.b:
        return units
    sa, sb = manifest_a.get("seed"), manifest_b.get("seed")
    if sa is not None and sb is not None:
        why = f"simulated sensors drawn from seeds {sa} and {sb}"
    else:
        why = "the sensors' identities differ (address, identity register or simulated seed)"
    return Units(units.a, units.b, True, why)
