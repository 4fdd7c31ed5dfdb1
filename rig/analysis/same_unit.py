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

A calibration applied to a session (``rig evaluate``, ``rig apply``: :func:`calibration_units`) is judged the
same way through the session it was solved from (its ``session:`` id, found in the calibration's own directory
or beside the session), else by the calibration's ``sensor.serial`` against the session's.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

from rig.analysis.sensor_key import get_path, sensor_identity
from rig.errors import RigInputError
from rig.session import SessionManifest

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


def _field(obj, name: str):
    """``obj.name`` or ``obj[name]`` (a calibration file's typed section or a plain mapping); None without."""
    return obj.get(name) if isinstance(obj, dict) else getattr(obj, name, None)


def _solved_from(cal, calibration_path, session_path) -> dict | None:
    """The manifest (plain mapping) of the session the calibration was solved from, when it can be found: the
    calibration's own directory (``rig run`` and ``rig solve`` write it into its session), or a session of that
    id beside the one at hand. None otherwise (a calibration copied away from its session)."""
    solved = _field(cal, "session")
    if not solved:
        return None
    for folder in (Path(calibration_path).parent, Path(session_path).parent / str(solved)):
        try:
            info, _ = SessionManifest.load(folder)
        except (RigInputError, OSError):
            continue
        if info.id == solved:
            return info.to_dict()
    return None


def calibration_units(cal, calibration_path, manifest: dict, session_path) -> Units | None:
    """Is the calibration (read from ``calibration_path``) of the unit the session at ``session_path`` (its
    manifest, a plain mapping) recorded? :func:`units_of` on the two sessions when the calibration's own session
    is found (:func:`_solved_from`), else the calibration's ``sensor.serial`` against the session's. Returns the
    Units (``different`` set when they are two units), or None when nothing can be told."""
    if _field(cal, "session") and _field(cal, "session") == manifest.get("id"):
        return None  # its own session
    own = _solved_from(cal, calibration_path, session_path)
    if own is not None:
        return units_of(own, manifest)
    serial = _field(_field(cal, "sensor") or {}, "serial")
    theirs = sensor_identity(manifest, None)
    if serial not in (None, "") and theirs["serial"] is not None and str(serial) != theirs["serial"]:
        model = _field(_field(cal, "sensor") or {}, "model") or theirs["model"]
        return Units(f"{model}:{serial}", theirs["key"], True, f"serials {serial} and {theirs['serial']}")
    return None


def other_unit_note(units: Units | None, calibration_path) -> str | None:
    """The one note when a calibration is applied to a session of another unit (``rig evaluate``, ``rig apply``):
    both identities and the evidence; None when the units are not known to differ."""
    if units is None or not units.different:
        return None
    return (f"note: {calibration_path} is the calibration of another unit ({units.a}) than the session recorded "
            f"({units.b}; {units.why}): what it gives for these counts carries the two units' differences, not "
            "only its own errors")
