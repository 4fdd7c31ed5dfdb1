"""Poses not where the session says: the recorded directions against the nominal poses, beyond the noise.

A method that trusts the nominal poses (pinv, combinations, flip) fits ``a_k = M f_k + b`` with ``f_k`` the
pose's nominal direction. A hand-placed face is off by degrees; the fit absorbs part of it into the
misalignment and scale terms and leaves the rest as residuals far beyond the noise (chi2/dof in the
thousands on a real six-face recording), while rows that happen to fit keep tiny sigmas: the numbers are
confidently wrong. :func:`check_placement` measures, for each step with a known pose, the angle between
the calibrated direction of its mean, ``M^-1 (a_k - b)``, and the nominal one, and its noise (the step
mean's standard error in g, across the direction). The poses are *misplaced* when the fit's misfit is
significant (the one rule, :meth:`calib.accel.result.AccelCalibration.misfit`) and some step's angle is
beyond :data:`K_SIGMA` times its noise and at least :data:`MIN_ANGLE_DEG`: what is left then is the
placement, not the sensor.

The angles are those the fit could not absorb (a lower bound of the misplacement: a pose turned about
gravity, or a common tilt, leaves none); they are reported per step. Any misfit the model lacks (a bias
that moves with temperature when the thermal model is off) also leaves angles, so the check is asked
only where the poses can be misplaced: sessions without a turntable (imports, faces placed by hand;
:func:`rig.analysis.solve.placement`). On a turntable the poses are the motors' and a misfit is an effect
the model lacks (``rig discover``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.accel.inputs import StepMeans

#: a step is misplaced when its angle exceeds this many times its noise ...
K_SIGMA = 5.0
#: ... and this angle (deg): a turntable's own pose errors are around 0.01 deg
MIN_ANGLE_DEG = 0.05
#: the pose-free (magnitude) method needs this many static steps in well-spread directions
MAGNITUDE_MIN_STEPS = 10


@dataclass(frozen=True)
class Placement:
    """The recorded directions against the nominal poses.

    Attributes
    ----------
    names : step names (known poses only).
    angle_deg : (K,) angle between the calibrated mean direction and the nominal pose, deg.
    noise_deg : (K,) 1-sigma of that angle from the step's standard error, deg.
    misfit : whether the fit's chi-square is beyond the noise (the one rule).
    """

    names: tuple
    angle_deg: np.ndarray
    noise_deg: np.ndarray
    misfit: bool

    @property
    def beyond(self) -> np.ndarray:
        """(K,) bool: the steps whose angle is beyond the noise (and beyond a turntable's pose errors)."""
        return (self.angle_deg > K_SIGMA * self.noise_deg) & (self.angle_deg >= MIN_ANGLE_DEG)

    @property
    def misplaced(self) -> bool:
        return bool(self.misfit and self.beyond.any())

    def per_step(self, limit: int = 12) -> str:
        """``+X up 4.8 deg, -Y up 3.1 deg, ...`` (the largest first, at most ``limit``)."""
        order = np.argsort(-self.angle_deg)[:limit]
        text = ", ".join(f"{self.names[i]} {self.angle_deg[i]:.2f} deg" for i in order)
        return text + (" ..." if len(self.names) > limit else "")

    def message(self, session: str, n_static: int) -> str:
        """One line: the misplacement per step, the noise, and the command to run instead."""
        noise = float(np.median(self.noise_deg))
        head = (f"the recorded directions disagree with the nominal poses beyond the noise (noise {noise:.3f} deg): "
                f"{self.per_step()}; the poses are not where the session says (hand-placed?), and a fit on them "
                "gives sigmas the pose error makes false")
        if n_static >= MAGNITUDE_MIN_STEPS:
            return f"{head}; solve without the poses: rig solve {session} --method magnitude"
        return (f"{head}; the pose-free method (rig solve {session} --method magnitude) needs {MAGNITUDE_MIN_STEPS} or "
                f"more rests in different directions and this session has {n_static}: record the faces on a "
                "fixture, or add rests in other orientations (docs/import.md, 'Hand-placed faces'); --trust-poses "
                "solves on the nominal poses anyway")

    def to_dict(self) -> dict:
        return {"misplaced": self.misplaced, "misfit": self.misfit,
                "steps": [{"name": str(n), "angle_deg": float(a), "noise_deg": float(s), "beyond_noise": bool(b)}
                          for n, a, s, b in zip(self.names, self.angle_deg, self.noise_deg, self.beyond)]}


def check_placement(calibration, steps: StepMeans) -> Placement:
    """The directions of ``steps`` (known poses) calibrated by ``calibration`` against their nominal poses."""
    f = calibration.apply(steps.mean_counts, temp_c=steps.temp_c if calibration.temperature is not None else None,
                          t_s=steps.t_s)
    f0 = np.asarray(steps.f_nominal_g, float)
    unit = f / np.maximum(np.linalg.norm(f, axis=1), 1e-12)[:, None]
    unit0 = f0 / np.maximum(np.linalg.norm(f0, axis=1), 1e-12)[:, None]
    cos = np.clip(np.sum(unit * unit0, axis=1), -1.0, 1.0)
    angle = np.degrees(np.arccos(cos))
    # the step mean's standard error in g, across the nominal direction (its part along it moves no angle)
    m_inv = np.linalg.inv(np.asarray(calibration.matrix_counts_per_g, float))
    sem_g = np.abs(np.asarray(steps.sem_counts, float) @ np.abs(m_inv).T)
    sem_along = np.sqrt(np.sum((sem_g * unit0) ** 2, axis=1))
    sem_across = np.sqrt(np.maximum(np.sum(sem_g**2, axis=1) - sem_along**2, 0.0))
    noise = np.degrees(sem_across / np.maximum(np.linalg.norm(f, axis=1), 1e-12))
    return Placement(tuple(steps.names), angle, np.maximum(noise, 1e-9), bool(calibration.misfit()[0]))
