"""A unit's noise profile (``rig-noise/1``) in other tools' formats: Kalibr's ``imu.yaml`` and JSON
(``rig export PROFILE.json --to kalibr|json``; docs/exports.md, "Noise profiles").

Kalibr (ethz-asl/kalibr, wiki "IMU Noise Model") takes one figure per sensor in SI units, continuous time:

=============================  ========================  ===========================================
Kalibr key                     unit                      from the profile
=============================  ========================  ===========================================
accelerometer_noise_density    m/s^2/sqrt(Hz)            accelerometer N (g/sqrt(Hz)) x 9.80665
accelerometer_random_walk      m/s^3/sqrt(Hz)            accelerometer K (g/sqrt(s)) x 9.80665
gyroscope_noise_density        rad/s/sqrt(Hz)            gyroscope N (deg/s/sqrt(Hz)) x pi / 180
gyroscope_random_walk          rad/s^2/sqrt(Hz)          gyroscope K (deg/s/sqrt(s)) x pi / 180
update_rate                    Hz                        the characterised record's rate
=============================  ========================  ===========================================

One figure per sensor: the largest of the three axes (Kalibr weighs every axis alike; the largest is the
one that does not make the estimator overconfident). Kalibr's figures are the continuous-time densities,
which is what an Allan-deviation fit gives (N the deviation at 1 s, K its +1/2 slope at 3 s), so no
rate conversion applies. What Kalibr cannot hold: the bias instability B, a rate ramp, the magnetometer,
the per-axis figures and the intervals (``rig export --to json`` keeps them all). Kalibr's documentation
advises inflating the figures of a static characterisation for a moving platform; this export does not.
"""

from __future__ import annotations

import math

import yaml

from rig.errors import RigInputError
from rig.lab.exports import Export
from rig.lab.noise_profiles import NoiseProfile, load_profile

#: standard gravity, m/s^2 per g (the accelerometer's figures are in g)
G_MS2 = 9.80665
NOISE_TARGETS = ("kalibr", "json")
#: Kalibr key -> (sensor, term, factor to SI)
KALIBR_KEYS = {
    "accelerometer_noise_density": ("accel", "N", G_MS2),
    "accelerometer_random_walk": ("accel", "K", G_MS2),
    "gyroscope_noise_density": ("gyro", "N", math.pi / 180.0),
    "gyroscope_random_walk": ("gyro", "K", math.pi / 180.0),
}


def _largest(profile: NoiseProfile, sensor: str, term: str) -> float | None:
    noise = getattr(profile, sensor)
    if noise is None:
        return None
    values = [getattr(a, term) for a in (noise.x, noise.y, noise.z)]
    return max(v.value for v in values) if all(v is not None for v in values) else None


def kalibr_params(profile: NoiseProfile, rostopic: str = "/imu0") -> dict:
    """Kalibr's imu.yaml as a mapping; RigInputError (one line) when a figure Kalibr needs was not fitted."""
    out = {"rostopic": rostopic, "update_rate": float(profile.rate_hz)}
    for key, (sensor, term, factor) in KALIBR_KEYS.items():
        v = _largest(profile, sensor, term)
        if v is None:
            raise RigInputError(None, None, f"{sensor}.{term}",
                                f"Kalibr's {key} needs the {sensor} {term} of every axis; the profile of "
                                f"{profile.sensor.key} has none (characterise with --terms N,B,K)")
        out[key] = v * factor
    return out


def export_profile(profile: NoiseProfile, target: str) -> Export:
    """``profile`` exported to ``target`` (:data:`NOISE_TARGETS`)."""
    if target == "json":
        return Export("json", profile.model_dump_json(indent=2) + "\n")
    if target != "kalibr":
        raise RigInputError(None, None, "--to", f"a noise profile exports to {', '.join(NOISE_TARGETS)}, not {target!r}")
    params = kalibr_params(profile)
    head = (f"# Kalibr IMU noise model of {profile.sensor.key} (rig-noise/1 of {profile.measured_at}, session "
            f"{profile.session}): continuous-time densities, the largest axis; SI units (docs/exports.md)\n")
    return Export("kalibr", head + yaml.safe_dump(params, sort_keys=False), params,
                  dropped=["bias instability B", "rate ramp", "magnetometer", "per-axis figures", "intervals"])


def noise_summary(exp: Export) -> str:
    if not exp.dropped:
        return f"{exp.target}: holds the whole profile (nothing dropped)"
    return f"{exp.target}: holds one figure per sensor (the largest axis); cannot hold {', '.join(exp.dropped)}"


def read_profile_json(path) -> NoiseProfile | None:
    """The profile in ``path`` when the file is a ``rig-noise/1`` JSON document (validated: one line naming the file
    and key when it is not a valid one), else None (a calibration file, read as one)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return None
    if not head.lstrip().startswith(b"{") or b"rig-noise/1" not in head:
        return None
    return load_profile(path)
