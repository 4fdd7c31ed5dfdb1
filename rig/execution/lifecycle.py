"""``rig run``: open the rig, create or resume a session, run the procedure, solve.

This is the orchestration layer between the CLI and the runner; tests call it
directly or through :func:`rig.cli.main`.
"""

from __future__ import annotations

import hashlib
import secrets
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import yaml

from rig import __version__
from rig.devices.rig import AXES, RigHandles, open_rig
from rig.config.procedure import load_procedure, load_procedure_text
from rig.config.rigfile import load_rig_file
from rig.execution.engine import Runner, RunnerOptions, StepOutcome
from rig.session.store import SessionWriter
from rig.console import ConsoleUI


@dataclass
class RunResult:
    session_dir: Path
    status: str  # complete | aborted
    outcomes: list[StepOutcome]
    calibration_path: Path | None
    calibration: object | None


def default_rig_path() -> Path:
    return Path(__file__).resolve().parents[2] / "rigs" / "sim.yaml"


def resolve_rig(spec: str | None) -> Path:
    """``sim`` (or nothing) means the embedded simulated rig; otherwise a rig-file path."""
    if spec in (None, "sim"):
        return default_rig_path()
    return Path(spec)


def new_session_id(procedure_name: str, seed: int | None) -> str:
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    tail = f"s{seed}" if seed is not None else secrets.token_hex(2)
    return f"{procedure_name}-{stamp}-{tail}"


def identify(rig: RigHandles) -> dict:
    """Identity of every device, for the manifest's ``rig`` section."""
    turntable = {"kind": "standa-8smc" if rig.kind == "hardware" else f"{rig.kind}:8smc5-emulator",
                 "axes": {}}
    for name in AXES:
        ident = rig.stages[name].identify()
        ax = rig.axes[name]
        turntable["axes"][name] = {
            "port": ax.port, "serial": ident.serial_number, "firmware": ident.firmware,
            "device": ident.device, "sign": ax.sign, "home_offset_deg": ax.home_offset_deg,
        }
    sensor = rig.sensor
    sid = sensor.identify()
    sensor_info = {
        "model": sensor.model, "address": int(rig.sensor_address), "identity": sid.to_dict(),
        "accel_range_g": int(sensor.accel_range_g), "accel_lsb_per_g": float(sensor.accel_lsb_per_g),
        "sample_rate_hz": float(sensor.sample_rate_hz), "has_temperature": bool(sensor.has_temperature),
    }
    if getattr(sensor, "has_gyro", False):
        sensor_info["gyro_range_dps"] = getattr(sensor, "gyro_range_dps", None)
        sensor_info["gyro_lsb_per_dps"] = getattr(sensor, "gyro_lsb_per_dps", None)
    out = {"turntable": turntable, "sensor": sensor_info, "rig_file": rig.rig_file}
    if rig.site_field is not None:
        out["site"] = dict(rig.site_field)
    return out


def configure_magnetometer(procedure, rig: RigHandles, sensor_info: dict | None) -> None:
    """Configure the AK8975 when the procedure reads it (after the MPU-9150 enabled its bypass)."""
    if not procedure.sensor.magnetometer:
        return
    from rig.execution.engine import RunError
    if rig.magnetometer is None:
        raise RunError(f"the procedure reads the magnetometer, but the {rig.sensor_model} on this rig has none")
    rig.magnetometer.configure()
    if sensor_info is not None:
        sensor_info["magnetometer"] = {"model": "AK8975", "address": int(rig.magnetometer.address),
                                       "asa_factor": [float(x) for x in rig.magnetometer.asa_factor],
                                       "mag_lsb_per_ut": MAG_LSB_PER_UT}


def session_columns(procedure, rig: RigHandles) -> tuple[str, ...]:
    """CSV columns: the base ones, the gyroscope's when the sensor has one, the magnetometer's when
    the procedure reads it, and the stage angles."""
    from rig.session.store import BASE_COLUMNS
    cols = BASE_COLUMNS
    if getattr(rig.sensor, "has_gyro", False):
        cols += ("wx", "wy", "wz")
    if procedure.sensor.magnetometer:
        cols += ("mx", "my", "mz")
    return cols + ("a1_deg", "a2_deg", "a3_deg")


#: magnetometer readings are stored as integers of 0.01 uT in the session's mx, my, mz columns
MAG_LSB_PER_UT = 100.0


def run_procedure(procedure_path: str | None, *, rig_spec: str | None = None, out_dir="sessions",
                  seed: int | None = None, resume_dir=None, ui: ConsoleUI | None = None,
                  time_scale: float | None = None, solve: bool = True,
                  options: RunnerOptions = RunnerOptions()) -> RunResult:
    """Run (or resume) a procedure; return where the session is and how it ended.

    Raises the drivers' errors (TurntableError, SensorError), RigInputError,
    RunError and RunAborted; motors are stopped and the session marked
    aborted before any of them leaves this function.
    """
    ui = ui or ConsoleUI(quiet=True)
    if resume_dir is not None:
        writer, first_step = SessionWriter.resume(resume_dir)
        manifest = writer.manifest
        procedure = load_procedure_text(manifest["procedure"]["text"], manifest["procedure"].get("file") or "<session>")
        rig_file = load_rig_file(resolve_rig(manifest.get("rig", {}).get("rig_file") if rig_spec is None else rig_spec))
        seed = manifest.get("seed", 0) if seed is None else seed
        time_offset = _resume_time_offset(manifest)
        writer.event("resume", t_s=time_offset, first_step=first_step)
        ui.info(f"resuming {writer.session_dir} at step {first_step + 1}")
    else:
        procedure = load_procedure(procedure_path)
        rig_file = load_rig_file(resolve_rig(rig_spec))
        seed = 0 if seed is None else seed
        writer = None
        first_step = 0
        time_offset = 0.0

    rig = open_rig(rig_file, seed=seed, time_scale=time_scale, on_stage_event=None)
    try:
        if writer is None:
            text = Path(procedure_path).read_text()
            manifest = {
                "id": new_session_id(procedure.name, seed),
                "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                "status": "running",
                "seed": seed if rig.kind == "sim" else None,
                "procedure": {"name": procedure.name, "file": str(procedure_path),
                              "sha256": hashlib.sha256(text.encode()).hexdigest(), "text": text},
                "software": {"name": "rig-calibration", "version": __version__},
                "steps": [step.to_manifest() for step in procedure.expanded_steps()],
            }
            rig.sensor.configure(procedure.sensor_settings())
            manifest["rig"] = identify(rig)
            configure_magnetometer(procedure, rig, manifest["rig"]["sensor"])
            writer = SessionWriter.create(out_dir, manifest["id"], manifest, columns=session_columns(procedure, rig))
            if rig.truth is not None:
                (writer.session_dir / "sim_truth.yaml").write_text(
                    yaml.safe_dump(rig.truth, sort_keys=False))
            ui.info(f"session {writer.session_dir}")
        else:
            rig.sensor.configure(procedure.sensor_settings())
            configure_magnetometer(procedure, rig, None)
        _attach_stage_events(rig, writer)
        runner = Runner(procedure, rig, writer, ui, first_step=first_step, options=options,
                        time_offset_s=time_offset)
        try:
            runner.prepare(resuming=resume_dir is not None)
            outcomes = runner.run()
        except BaseException as exc:
            try:  # best effort: on a full disk even this may fail; what is on disk stays valid
                writer.event("abort", t_s=runner.session_time(), reason=_one_line(exc))
                writer.set_status("aborted")
            except OSError:
                pass
            raise
    finally:
        rig.close()

    cal = cal_path = None
    if solve and procedure.solve is not None:
        from calib.errors import CalibError
        from rig.execution.engine import RunError
        from rig.analysis.solve import solve_session
        flagged = [o.index + 1 for o in outcomes if o.status == "flagged"]
        try:
            cal, cal_path = solve_session(writer.session_dir)
        except CalibError as exc:
            writer.event("error", message=f"cannot solve: {exc}")
            writer.set_status("complete")
            if flagged:
                raise RunError(f"cannot solve: {exc} (steps {', '.join(map(str, flagged))} were flagged "
                               f"for bad data; session {writer.session_dir})") from None
            raise
        writer.event("solve", path=str(cal_path))
    writer.set_status("complete")
    return RunResult(writer.session_dir, "complete", outcomes, cal_path, cal)


def _attach_stage_events(rig: RigHandles, writer) -> None:
    def on_event(kind: str, detail: dict) -> None:
        writer.event("warning" if kind != "info" else "info", source="turntable", what=kind, **detail)
    for st in rig.stages.values():
        if hasattr(st, "on_event"):
            st.on_event = on_event


def _resume_time_offset(manifest: dict) -> float:
    ends = [s.get("stats", {}).get("t_end_s") for s in manifest.get("steps", [])
            if s.get("status") in ("complete", "flagged")]
    ends = [e for e in ends if e is not None]
    return (max(ends) + 1.0) if ends else 0.0


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}"
