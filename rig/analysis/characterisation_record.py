"""The rig's characterisation on disk (``rig-characterisation/1``, docs/uncertainty.md, "The rig's
characterisation record"): the turntable's errors estimated by reversal (``rig characterize-rig``), with their
standard uncertainties, dated and tied to the rig file by its sha256.

It lives next to the rig file as ``<rig file stem>.characterisation.yaml`` (:func:`default_path`); a session
whose rig file has the digest the record names gets it as its rig's ``known`` errors
(:func:`rig.analysis.uncertainty.session_rig_errors`), a session of another digest is told it was ignored.

    format: rig-characterisation/1
    date: 2026-11-26T03:10:00+00:00
    rig_file: {path: /abs/rigs/lab.yaml, sha256: 64 hex}
    session: characterize_reversal-20261126T030000Z-s3-66ee
    method: reversal
    mountings: [{name: x+z+, turn: as placed, steps: 6}, ...]
    estimates:                     # deg
      mounting.x: {estimate_deg: 0.0512, u_deg: 0.0011}
      ...
    aliases: [zero_offset.a1, zero_offset.a3, non_orthogonality.a1_a3]
    chi2_per_dof: 1.4
    dof: 18
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import yaml

from calib.accel.reversal import ALIASES, CHARACTERISED, Characterisation
from calib.file import yamlsafe
from calib.file.yamlsafe import HostileYaml
from rig.config.yamlload import input_error, read_source
from rig.errors import RigInputError

FORMAT = "rig-characterisation/1"
SUFFIX = ".characterisation.yaml"
_SHA256 = re.compile(r"^[0-9a-f]{64}$")


@dataclass(frozen=True)
class CharacterisationRecord:
    """A stored characterisation: the fit (:class:`calib.accel.reversal.Characterisation`), when it was made
    (``date``, ISO 8601), the rig file it belongs to (``rig_file``, ``rig_file_sha256``), the session it was
    made from, its mountings (name, turn in words, steps) and where it was read from (``path``)."""

    characterisation: Characterisation
    date: str
    rig_file: str
    rig_file_sha256: str
    session: str
    mountings: tuple = ()
    path: Path | None = None
    table_sha256: str | None = None  # the rig file without its run-time pacing keys (:func:`table_digest`)

    def to_dict(self) -> dict:
        c = self.characterisation
        return {"format": FORMAT, "date": self.date,
                "rig_file": {"path": self.rig_file, "sha256": self.rig_file_sha256,
                             **({"table_sha256": self.table_sha256} if self.table_sha256 else {})},
                "session": self.session, "method": "reversal", "mountings": [dict(m) for m in self.mountings],
                "estimates": {n: {"estimate_deg": float(c.estimate_deg[n]), "u_deg": float(c.u_deg[n]),
                                  **({"u_correction_deg": float(c.u_correction_deg[n])} if c.u_correction_deg else {})}
                              for n in c.estimate_deg},
                "aliases": list(ALIASES),
                "chi2_per_dof": float(c.chi2_per_dof), "dof": int(c.dof)}

    def to_yaml(self) -> str:
        return ("# the turntable's errors by reversal (rig characterize-rig, docs/uncertainty.md); used by every "
                "calibration\n# on the rig file of this sha256\n"
                + yaml.safe_dump(self.to_dict(), sort_keys=False))

    @property
    def label(self) -> str:
        """``reversal 2026-11-26 (lab.characterisation.yaml)``: which characterisation, for a budget's rig terms."""
        name = self.path.name if self.path is not None else "characterisation"
        return f"characterised by reversal {self.date[:10]} ({name})"


#: the keys of a simulated rig's ``sim:`` section that pace a run without changing the table (editing one keeps
#: a characterisation: the same table, run faster or slower)
PACING_KEYS = ("time_scale", "clock", "transport")


def table_digest(doc) -> str | None:
    """sha256 of a rig file's content ``doc`` (as parsed) without the ``sim:`` pacing keys (:data:`PACING_KEYS`), as
    canonical JSON: the same for a rig file whose only edit is how fast its simulation runs; None when ``doc`` is
    not a mapping."""
    if not isinstance(doc, dict):
        return None
    sim = doc.get("sim")
    if isinstance(sim, dict):
        doc = {**doc, "sim": {k: v for k, v in sim.items() if k not in PACING_KEYS}}
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()


def default_path(rig_file) -> Path:
    """Where a rig file's characterisation lives: next to it, ``<stem>.characterisation.yaml``."""
    p = Path(rig_file)
    return p.with_name(p.stem + SUFFIX)


def load_record(path) -> CharacterisationRecord:
    """Read and check a ``rig-characterisation/1`` file (RigInputError, one line naming the file and key)."""
    path = Path(path)
    where = str(path)
    try:  # the one guarded loader: size, depth, aliases, tags, duplicate keys (a hand-edited record is input)
        doc = yamlsafe.load(read_source(path, "rig characterisation", "no such characterisation file"))
    except HostileYaml as exc:
        raise input_error(exc, where) from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        got = doc.get("format") if isinstance(doc, dict) else type(doc).__name__
        raise RigInputError(where, None, "format", f"expected {FORMAT!r}, got {got!r}")
    rig = doc.get("rig_file")
    if not isinstance(rig, dict) or not isinstance(rig.get("sha256"), str) or not _SHA256.match(rig["sha256"]):
        raise RigInputError(where, None, "rig_file.sha256", "expected the rig file's sha256 (64 hex digits)")
    estimates = doc.get("estimates")
    if not isinstance(estimates, dict) or not estimates:
        raise RigInputError(where, None, "estimates", "expected a mapping of table errors to {estimate_deg, u_deg}")
    est, u, u_fix = {}, {}, {}
    for name, e in estimates.items():
        if name not in CHARACTERISED:
            raise RigInputError(where, None, f"estimates.{name}",
                                f"not a characterised table error (expected one of {', '.join(CHARACTERISED)})")
        values = [e.get(k) if isinstance(e, dict) else None for k in ("estimate_deg", "u_deg")]
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values) \
                or values[1] < 0:
            raise RigInputError(where, None, f"estimates.{name}", "expected {estimate_deg: number, u_deg: number >= 0}")
        est[name], u[name] = float(values[0]), float(values[1])
        uc = e.get("u_correction_deg")
        if uc is not None:
            if not (isinstance(uc, (int, float)) and not isinstance(uc, bool) and math.isfinite(uc) and uc >= 0):
                raise RigInputError(where, None, f"estimates.{name}.u_correction_deg", "expected a number >= 0")
            u_fix[name] = float(uc)
    chi2 = doc.get("chi2_per_dof")
    dof = doc.get("dof")
    return CharacterisationRecord(
        Characterisation(est, u, float(chi2) if isinstance(chi2, (int, float)) else float("nan"),
                         int(dof) if isinstance(dof, int) else 0, u_correction_deg=u_fix if len(u_fix) == len(u) else None),
        date=str(doc.get("date", "")), rig_file=str(rig.get("path", "")), rig_file_sha256=rig["sha256"],
        session=str(doc.get("session", "")), mountings=tuple(doc.get("mountings") or ()), path=path,
        table_sha256=rig["table_sha256"] if isinstance(rig.get("table_sha256"), str)
        and _SHA256.match(rig["table_sha256"]) else None)


def find_record(rig_file) -> CharacterisationRecord | None:
    """The characterisation stored next to ``rig_file`` (:func:`default_path`), or None when there is none."""
    path = default_path(rig_file)
    return load_record(path) if path.is_file() else None
