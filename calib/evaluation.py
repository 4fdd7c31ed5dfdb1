"""Evaluation of a calibration against known poses, in the layout of the seed paper's table."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.accel.inputs import StepMeans

GIMBAL_LOCK_COS = 0.05  # |cos pitch| below this: roll is undefined and not scored


def roll_pitch_deg(f) -> tuple[np.ndarray, np.ndarray]:
    """Euler-Krylov roll psi = -atan(gx/gz), pitch theta = atan(gy/(gz cos psi - gx sin psi)), deg, quadrant-safe."""
    f = np.atleast_2d(np.asarray(f, float))
    gx, gy, gz = f[:, 0], f[:, 1], f[:, 2]
    psi = np.arctan2(-gx, gz)
    theta = np.arctan2(gy, gz * np.cos(psi) - gx * np.sin(psi))
    return np.degrees(psi), np.degrees(theta)


def f_from_roll_pitch(roll_deg, pitch_deg) -> np.ndarray:
    """Specific force for the seed's roll (psi) and pitch (theta): f = (-sin r cos p, sin p, cos r cos p)."""
    r, p = np.radians(np.asarray(roll_deg, float)), np.radians(np.asarray(pitch_deg, float))
    return np.stack([-np.sin(r) * np.cos(p), np.sin(p), np.cos(r) * np.cos(p)], axis=-1)


def _wrap(d):
    return (np.asarray(d) + 180.0) % 360.0 - 180.0


@dataclass(frozen=True)
class EvaluationRow:
    name: str
    roll_deg: float
    pitch_deg: float
    roll_error_deg: float | None  # None at gimbal lock
    pitch_error_deg: float
    angle_error_deg: float
    norm_error_g: float  # |f| - 1


@dataclass(frozen=True)
class Evaluation:
    rows: list

    def max_abs(self, key: str) -> float:
        v = [abs(getattr(r, key)) for r in self.rows if getattr(r, key) is not None]
        return max(v) if v else float("nan")

    def to_dict(self) -> dict:
        return {"steps": [r.__dict__ for r in self.rows],
                "max_abs_roll_error_deg": self.max_abs("roll_error_deg"),
                "max_abs_pitch_error_deg": self.max_abs("pitch_error_deg"),
                "max_angle_error_deg": self.max_abs("angle_error_deg"),
                "max_abs_norm_error_g": self.max_abs("norm_error_g")}

    def format_table(self) -> str:
        """The seed paper's table as a person reads it: angles in deg, ``|f| - 1`` in ug (as every residual the
        tool prints; ``to_dict`` keeps g)."""
        head = f"{'step':<22} {'roll/pitch, deg':>16} {'error roll/pitch, deg':>23} {'angle err, deg':>15} {'|f|-1, ug':>11}"
        lines = [head, "-" * len(head)]
        for r in self.rows:
            re = "   n/a" if r.roll_error_deg is None else f"{r.roll_error_deg:+7.3f}"
            roll, pitch = (round(x, 1) + 0.0 for x in (r.roll_deg, r.pitch_deg))  # never "-0.0" for a nominal 0
            lines.append(f"{r.name[:22]:<22} {roll:7.1f}/{pitch:<7.1f}  {re:>10}/{r.pitch_error_deg:<+9.3f}"
                         f"   {r.angle_error_deg:12.4f} {r.norm_error_g * 1e6:+11.1f}")
        lines.append(f"max |error|: roll {self.max_abs('roll_error_deg'):.3f} deg, pitch "
                     f"{self.max_abs('pitch_error_deg'):.3f} deg, angle {self.max_abs('angle_error_deg'):.4f} deg, "
                     f"||f| - 1| {self.max_abs('norm_error_g') * 1e6:.1f} ug")
        return "\n".join(lines)


def evaluate(calibration, steps: StepMeans) -> Evaluation:
    """Apply ``calibration`` to each step mean and compare with the nominal pose."""
    f = calibration.apply(steps.mean_counts, temp_c=steps.temp_c if calibration.temperature is not None else None,
                          t_s=steps.t_s)
    f0 = np.asarray(steps.f_nominal_g, float)
    r_m, p_m = roll_pitch_deg(f)
    r_n, p_n = roll_pitch_deg(f0)
    rows = []
    for i in range(len(steps)):
        locked = abs(np.cos(np.radians(p_n[i]))) < GIMBAL_LOCK_COS
        cosang = np.dot(f[i], f0[i]) / (np.linalg.norm(f[i]) * np.linalg.norm(f0[i]))
        rows.append(EvaluationRow(
            name=str(steps.names[i]), roll_deg=float(r_n[i]), pitch_deg=float(p_n[i]),
            roll_error_deg=None if locked else float(_wrap(r_m[i] - r_n[i])),
            pitch_error_deg=float(_wrap(p_m[i] - p_n[i])),
            angle_error_deg=float(np.degrees(np.arccos(np.clip(cosang, -1, 1)))),
            norm_error_g=float(np.linalg.norm(f[i]) - 1.0)))
    return Evaluation(rows)
