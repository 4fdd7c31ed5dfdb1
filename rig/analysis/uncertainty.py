"""The uncertainty budget of a session's accelerometer calibration (docs/uncertainty.md): the rig's Type B
inputs from its rig file (gravity, approach direction, turntable classes) and ``accelerometer.uncertainty``
made by :func:`calib.accel.budget.uncertainty_section` with the solve the session used.

``rig.analysis.solve.calibrate_session`` attaches it to every pose-method solve (pinv, combinations):
:func:`session_budget`. A session whose rig file is not there unchanged (an import, a rig file edited since)
gets the turntable's datasheet classes and the budget's rig terms say so (their ``source``). A rig characterised
by reversal (``rig characterize-rig``: ``<rig file stem>.characterisation.yaml`` next to the rig file, made on a
rig file of the session's sha256) gives its estimated table errors: the session's poses are put where the
characterised table puts them and the estimates' standard uncertainties replace their classes
(:class:`CharacterisedRig`); a record made on another digest is ignored, and the rig terms say so.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace


import calib
from calib.file import yamlsafe
from calib.accel.budget import at_local_gravity, has_linear_map, linear_solve, uncertainty_section
from calib.accel.inputs import StepMeans
from calib.accel.result import AccelCalibration
from calib.gyro import GyroCalibration
from calib.gyro.budget import uncertainty_section as gyro_uncertainty
from calib.mag import MagCalibration, MagStepMeans
from calib.mag.budget import uncertainty_section as mag_uncertainty
from calib.numerics.budget import DEFAULT_K, RigErrors, TableClass
from calib.numerics.gravity import G0_M_S2, Gravity, standard_gravity
from rig.analysis.characterisation_record import CharacterisationRecord, find_record, table_digest
from rig.config.rigfile import GravityConfig, RigFile, load_rig_file, simulated_table
from rig.errors import RigInputError
from rig.planning.kinematics import STAGE_AXES

_CLASS_KEYS = tuple(f.name for f in dataclasses.fields(TableClass))
#: the classes of a table without errors (the simulated table with sim.geometry off)
PERFECT_TABLE = TableClass(**{k: (TableClass.period_deg if k == "period_deg" else 0.0) for k in _CLASS_KEYS})


@dataclass(frozen=True)
class RigFacts:
    """What the budget reads of a rig file (:func:`rig_errors` takes it as it takes a :class:`RigFile`): its
    ``path``, whether it ``is_simulated``, its ``sim`` section (``geometry``), each axis' ``approach`` and its
    ``gravity``."""

    path: Path
    is_simulated: bool
    sim: dict
    axes: dict
    gravity: Gravity
    table_sha256: str | None = None  # the file without its simulation's pacing keys (characterisation_record.table_digest)


def session_rig_facts(session) -> RigFacts | None:
    """What the budget needs of the session's rig file, when that is still there and unchanged (its recorded
    sha256), else None. Read without validating it again: its bytes are those the run validated (the digest says
    so), and a full parse would load the simulator's schemas into every ``rig solve`` of a simulated session. The
    facts of one file's bytes are parsed once per process (:func:`_rig_facts`, keyed by the digest just checked):
    an archive re-solved in one process reads its few rig files once each."""
    found = _unchanged_rig_file_bytes(session)
    return None if found is None else _rig_facts(*found)


@functools.lru_cache(maxsize=64)
def _rig_facts(path: Path, digest: str, data: bytes) -> RigFacts | None:
    try:
        doc = yamlsafe.load(data.decode("utf-8"))  # the guarded loader's fast path (libyaml events)
        sim = doc.get("sim") or {}
        axes = (doc.get("turntable") or {}).get("axes") or {}
        stated = doc.get("gravity")
        gravity = GravityConfig(**stated).resolve() if stated else standard_gravity()
        return RigFacts(path, doc.get("kind") == "sim", sim if isinstance(sim, dict) else {},
                        {n: SimpleNamespace(approach=(axes.get(n) or {}).get("approach", "none")) for n in STAGE_AXES},
                        gravity, table_digest(doc))
    except (ValueError, TypeError, AttributeError, UnicodeDecodeError, yamlsafe.HostileYaml):
        return None


def _unchanged_rig_file_bytes(session) -> tuple[Path, str, bytes] | None:
    """The session's rig file (path, sha256, bytes) when it is still there with the sha256 the run recorded."""
    rig = session.info.rig
    path, digest = rig.rig_file, rig.rig_file_sha256
    if not path or not digest:
        return None
    p = Path(path) if Path(path).is_absolute() else Path.cwd() / path
    try:
        data = p.read_bytes()
    except OSError:
        return None
    return (p, digest, data) if hashlib.sha256(data).hexdigest() == digest else None


def _unchanged_rig_file(session) -> Path | None:
    """The session's rig file when it is still there with the sha256 the run recorded, else None."""
    found = _unchanged_rig_file_bytes(session)
    return None if found is None else found[0]


def session_rig_file(session) -> RigFile | None:
    """The session's rig file when it is still there and unchanged (its recorded sha256), else None."""
    path = _unchanged_rig_file(session)
    try:
        return None if path is None else load_rig_file(path)
    except (OSError, RigInputError):
        return None


#: where the rig terms come from when the session's rig file is not known (``RigErrors.source``)
DATASHEET_SOURCE = "turntable datasheet classes (docs/simulated-rig.md), no characterisation"


def session_rig_errors(session) -> RigErrors:
    """The rig's Type B inputs for a session: from its rig file when that is there unchanged
    (:func:`session_rig_file`), else the turntable's datasheet classes at standard gravity, the source saying
    why (an imported session has no rig file; a recorded one's may have changed or gone)."""
    rig_file = session_rig_facts(session)
    if rig_file is not None:
        return characterised(rig_errors(rig_file), rig_file.path, session.info.rig.rig_file_sha256,
                             rig_file.table_sha256)
    info = session.info
    rig = info.rig
    if info.import_ is not None or rig.kind == "import":
        why = "no rig file: an imported session"
    elif getattr(info, "replay_of", None):
        why = "no rig file: a replay of a recorded session"
    elif not rig.rig_file or not rig.rig_file_sha256:
        why = "the session records no rig file"
    else:
        why = f"the session's rig file {Path(rig.rig_file).name} is not there unchanged (sha256)"
    return dataclasses.replace(RigErrors.from_classes(), source=f"{DATASHEET_SOURCE}; {why}")


def rig_errors(rig_file: RigFile | RigFacts | None) -> RigErrors:
    """The rig's Type B inputs: its stated gravity, whether every axis approaches its poses from one side, and
    the turntable's classes (a simulated rig's ``sim.geometry`` classes, none when they are off; a hardware rig's
    the datasheet classes). Needs a wired program (``rig.composition.wire``: the command line is) to read a
    simulated rig file; unread, the session's rig is taken at its datasheet classes."""
    if rig_file is None:
        return dataclasses.replace(RigErrors.from_classes(), source=DATASHEET_SOURCE)
    geometry = (rig_file.sim or {}).get("geometry") or {}
    table = TableClass(**{k: float(v) for k, v in geometry.items() if k in _CLASS_KEYS})
    source = f"rig file {Path(rig_file.path).name}: " + ("sim.geometry classes" if geometry else "datasheet classes")
    if rig_file.is_simulated and simulated_table(rig_file.sim) is None:
        table = PERFECT_TABLE  # a simulated table without its errors (sim.geometry off) lands where commanded
        source = f"rig file {Path(rig_file.path).name}: simulated turntable without geometry errors (sim.geometry off)"
    approaching = [rig_file.axes[n].approach != "none" for n in STAGE_AXES]
    rig = RigErrors.from_classes(table, rig_file.gravity, one_direction=all(approaching))
    return dataclasses.replace(rig, source=source + ", no characterisation", mixed_approach=any(approaching) and
                               not all(approaching))


@dataclass(frozen=True)
class CharacterisedRig(RigErrors):
    """A rig's Type B inputs with its characterisation by reversal (``record``): ``known`` holds the estimated
    table errors' standard uncertainties (their aliases 0), and :func:`with_budget` moves the session's poses
    where the characterised table puts them before it solves."""

    record: CharacterisationRecord | None = None


def characterised(rig: RigErrors, rig_file, digest: str | None, table: str | None = None) -> RigErrors:
    """``rig`` with the characterisation stored next to ``rig_file`` when it was made on a rig file of sha256
    ``digest``, or of the same table (``table``: :func:`~rig.analysis.characterisation_record.table_digest`, the
    file without its simulation's pacing keys) (:class:`CharacterisedRig`, its source naming the record and its
    date); a record of another rig file, or one that cannot be read, is ignored and the source says so in one
    line; no record: ``rig`` as it is."""
    try:
        record = find_record(rig_file)
    except (OSError, RigInputError) as exc:
        return dataclasses.replace(rig, source=f"{rig.source}; its characterisation is ignored: {exc}")
    if record is None:
        return rig
    same_table = (record.table_sha256 is not None and table is not None and record.table_sha256 == table)
    if record.rig_file_sha256 != digest and not same_table:
        return dataclasses.replace(rig, source=(
            f"{rig.source}; characterisation {record.path.name} ({record.date[:10]}) ignored: made on rig file "
            f"sha256 {record.rig_file_sha256[:12]}.., this session's is {str(digest)[:12]}.."))
    source = rig.source.replace(", no characterisation", "") + f", {record.label}"
    known = record.characterisation.rig_errors(rig, source)
    return CharacterisedRig(**{f.name: getattr(known, f.name) for f in dataclasses.fields(RigErrors)}, record=record)


def resolver(accel: AccelCalibration, model: str, method: str):
    """A solve of perturbed steps the same way ``accel`` was solved (its thermal order and t0 fixed)."""
    thermal = accel.temperature.order if accel.temperature is not None else "off"
    t0 = accel.temperature.t0_c if accel.temperature is not None else None
    return lambda steps: calib.solve(steps, model=model, method=method, thermal=thermal, t0_c=t0)


def with_gyro_budget(gyro: dict, rig: RigErrors, k: float = DEFAULT_K) -> dict:
    """The gyroscope section ``gyro`` (a dict, as the solve gives it) with its ``uncertainty``
    (:func:`calib.gyro.budget.uncertainty_section`: the table's frame and brackets in its nonorthogonalities);
    ``sigma`` unchanged."""
    section = GyroCalibration.from_dict(gyro)
    return {**gyro, "uncertainty": gyro_uncertainty(section, rig, k)}


def with_mag_budget(mag: MagCalibration, steps: MagStepMeans, rig: RigErrors, k: float = DEFAULT_K) -> dict:
    """The magnetometer section of a positions solve (``mag`` of ``steps``) with its ``uncertainty``
    (:func:`calib.mag.budget.uncertainty_section`: the table's frame and each pose's own error), as a dict;
    ``sigma`` unchanged."""
    return {**mag.to_dict(), "uncertainty": mag_uncertainty(mag, steps, rig, k)}


def with_budget(accel: AccelCalibration, steps: StepMeans, model: str, method: str, rig: RigErrors,
                k: float = DEFAULT_K) -> AccelCalibration:
    """``accel`` with its ``uncertainty`` (U = k u_c, k, the budget); ``sigma`` unchanged. On a characterised rig
    (:class:`CharacterisedRig`) the session is first solved again at the poses the characterised table puts it
    (``Characterisation.corrected``), which is what the budget's characterised terms assume. Where the rig file
    states a local g other than g0, the session is first solved again at that g (``at_local_gravity``: the
    scale factors in g0 of the file), which is what the budget's gravity term assumes."""
    resolve = resolver(accel, model, method)
    record = getattr(rig, "record", None)
    if record is not None:  # the poses where the characterised table puts them (docs/uncertainty.md)
        steps = record.characterisation.corrected(steps, rig)
    if rig.gravity.g_m_s2 != G0_M_S2:
        steps = at_local_gravity(steps, rig.gravity)
    if record is not None or rig.gravity.g_m_s2 != G0_M_S2:
        accel = resolve(steps)
    linear = linear_solve(accel, steps) if has_linear_map(accel) else None
    section = uncertainty_section(accel, steps, resolve, rig, k, linear=linear)
    return accel.model_copy(update={"uncertainty": section})
