"""The pipeline tail: one way from a recorded session to its calibration file (docs/architecture.md).

    session (loaded once) -> solve -> target record -> acceptance verdict -> calibration file (written
    once) -> history record -> report (when the procedure asks)

``rig run``, ``rig solve``, ``rig replay`` and :func:`rig.workflow.run.run_procedure` all end here, so
the Python API returns exactly what the command line prints: the same calibration, verdict and
history entry. Nothing is read back from disk: the session is read once (manifest, samples, recorded
procedure, events), the calibration is judged in memory and written once, the history row and the
report are made from what is in memory.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from calib.acceptance import Acceptance
from calib.file import calibration as calfile
from calib.file.calibration import CalibrationFile
from rig.analysis.solve import calibrate_session
from rig.lab.acceptance import judge
from rig.lab.history import record_calibration
from rig.lab.noise_profiles import use_unit_profile
from rig.lab.recording_noise import use_recording_noise
from rig.session import Session


@dataclass
class Conclusion:
    """What the pipeline tail made of one session.

    Attributes
    ----------
    session : the session, as read once.
    calibration : the calibration file's content (with ``acceptance:`` when the procedure has limits).
    calibration_path : where it was written.
    acceptance : the verdict, or None when the procedure has no ``accept:`` limits.
    history_warning : None when the calibration went into the history; else the one-line reason it did
        not (the calibration stands: a history problem never changes a result).
    report_path : the HTML report written because the procedure asks for one (``report: true``), or None.
    report_warning : None, or the one-line reason the report asked for could not be written (the calibration,
        its verdict and its history record stand: ``rig report SESSION`` writes the report later).
    """

    session: Session
    calibration: CalibrationFile
    calibration_path: Path
    acceptance: Acceptance | None
    history_warning: str | None = None
    report_path: Path | None = None
    report_warning: str | None = None

    @property
    def verdict(self) -> str | None:
        """``PASS``/``FAIL``, or None without limits."""
        return None if self.acceptance is None else self.acceptance.verdict

    @property
    def passed(self) -> bool:
        """True unless an acceptance limit failed."""
        return self.acceptance is None or self.acceptance.passed


def conclude(session: Session, *, out=None, model: str | None = None, method: str | None = None, thermal=None,
             history=None, sensor_id: str | None = None, report: bool | None = None, record: bool = True) -> Conclusion:
    """Solve a loaded session, judge it, write its calibration file once, record it, report it.

    Parameters
    ----------
    session : the session (``rig.session.load_session``).
    out : path of the calibration file (default ``SESSION/calibration.yaml``).
    model, method, thermal : override the procedure's ``solve:`` settings (:func:`calibrate_session`).
    history : history database (default ``$RIG_HISTORY``, else the user's).
    sensor_id : a serial or fixture id that overrides the sensor key built from the manifest.
    report : write ``SESSION/report.html``; default: when the recorded procedure says ``report: true``.
    record : put the calibration into the history (False: an exploratory re-solve, ``rig solve --no-record``).
        :func:`write_conclusion_report` writes it later for a caller that concludes before the session
        is marked complete (``rig run``).

    Raises CalibError (the session cannot be solved), SessionFormatError; nothing is written then.
    """
    # the unit's own noise figures when it was characterised, else its steps' own when they are long enough to show them
    noise = use_unit_profile(session, history) or use_recording_noise(session)
    cal = calibrate_session(session.path, model=model, method=method, thermal=thermal, session=session)
    if noise is not None:
        cal = cal.model_copy(update={"noise": noise})
    path = Path(out) if out is not None else session.path / "calibration.yaml"
    acceptance = judge(session, cal, calibration_path=path, history=history)
    if acceptance is not None:
        cal = cal.model_copy(update={"acceptance": acceptance.to_dict()})
    calfile.write(path, cal)
    warning = record_calibration(session.path, path, history=history, sensor_id=sensor_id,
                                 verdict=None if acceptance is None else acceptance.verdict,
                                 manifest=session.info.to_dict(), calibration=cal) if record else None
    conclusion = Conclusion(session, cal, path, acceptance, warning)
    if report if report is not None else report_asked(session):
        write_conclusion_report(conclusion, history=history)
    return conclusion


def report_asked(session: Session) -> bool:
    """Whether the recorded procedure asks for the HTML report at the end (``report: true``)."""
    return session.procedure_asks("report") is True


def write_conclusion_report(conclusion: Conclusion, *, history=None, session: Session | None = None) -> Path | None:
    """Write the conclusion's HTML report (``SESSION/report.html``) from what is in memory; ``session``:
    a fresher view of the same session (its final status), when the caller has one. A report that cannot be
    written (a full disk, ...) is :attr:`Conclusion.report_warning`, never the loss of the calibration written
    before it: None is returned then."""
    from rig.lab.report import write_report  # deferred: the page and its figures, only when a report is asked

    if session is not None:
        conclusion.session = session
    try:
        conclusion.report_path = write_report(conclusion.session.path, history_db=history,
                                              calibration=conclusion.calibration_path, session=conclusion.session,
                                              calibration_file=conclusion.calibration)
    except Exception as exc:  # noqa: BLE001 -- the report is the last thing made: its failure leaves the rest standing
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        conclusion.report_warning = (f"report not written ({type(exc).__name__}: {first}); the calibration stands: "
                                     f"write the report with rig report {conclusion.session.path}")
    return conclusion.report_path
