"""Gyroscope (rate steps) and magnetometer (positions / ellipsoid) calibration, on synthetic data.

Truth comes from the simulator's error models (drivers.sensors.sim.error_model); the step
means get Gaussian noise with a known standard error, so the reported sigmas can be checked.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calib.errors import CalibError, CalibrationFileError, ObservabilityError
from calib.gyro import GyroCalibration, RateStepMeans, param_names, solve_gyro
from calib.mag import MagCalibration, MagStepMeans, sigma_names, solve_mag_ellipsoid, solve_mag_positions
from calib.numerics.stability import BiasStability
from drivers.sensors.sim.error_model import GyroErrorModel, MagErrorModel

SENSOR_AXES = "xyz"
LSB_PER_DPS = 131.0  # +-250 deg/s range
NOISE_DPS = 0.005 * np.sqrt(5.0)  # 0.005 deg/s/rtHz at 10 Hz sampling (5 Hz bandwidth), per sample
N_GYRO = 1000  # 100 s at 10 Hz
F_G = np.array([0.0, 0.0, 1.0])  # constant specific force on the table, g
FIELD_UT = 50.0
INCLINATION = np.radians(60.0)
EARTH_FIELD = FIELD_UT * np.array([np.cos(INCLINATION), 0.0, np.sin(INCLINATION)])  # north, east, down
MAG_NOISE_UT = 0.3
N_MAG = 100  # 10 s at 10 Hz


# ------------------------------------------------------------------ synthetic data

def seed_rate_modes(axes: str = "xyz") -> tuple[tuple, np.ndarray]:
    """The seed's 18 modes: +-25, +-40, +-63 deg/s about each axis (names, rates (K, 3) deg/s)."""
    names, rates = [], []
    for a in axes:
        for r in (25.0, 40.0, 63.0):
            for s in (+1, -1):
                w = np.zeros(3)
                w[SENSOR_AXES.index(a)] = s * r
                names.append(f"{a}{'+' if s > 0 else '-'}{r:g}")
                rates.append(w)
    return tuple(names), np.array(rates)


def gyro_truth(model: GyroErrorModel) -> tuple[np.ndarray, np.ndarray]:
    """(M counts per deg/s, b counts) of the simulator model for a constant specific force F_G."""
    m = LSB_PER_DPS * np.asarray(model.matrix)
    b = LSB_PER_DPS * (np.asarray(model.bias_dps) + np.asarray(model.g_sensitivity_dps_per_g) @ F_G)
    return m, b


def gyro_steps(model: GyroErrorModel, rng: np.random.Generator, axes: str = "xyz") -> RateStepMeans:
    names, w = seed_rate_modes(axes)
    true = LSB_PER_DPS * model.output_dps(w, np.tile(F_G, (len(w), 1)))
    sem = np.full(w.shape, NOISE_DPS * LSB_PER_DPS / np.sqrt(N_GYRO))
    return RateStepMeans(names, w, true + rng.normal(size=w.shape) * sem, sem, np.full(len(w), N_GYRO),
                         LSB_PER_DPS)


def gyro_named_truth(m: np.ndarray, b: np.ndarray) -> dict:
    out = {f"b_{a}": b[i] for i, a in enumerate(SENSOR_AXES)}
    out.update({f"k_{a}": m[i, i] for i, a in enumerate(SENSOR_AXES)})
    out.update({f"m_{SENSOR_AXES[i]}{SENSOR_AXES[j]}": m[i, j] / m[i, i] for i in range(3) for j in range(3) if i != j})
    return out


def gyro_named_estimate(cal: GyroCalibration) -> dict:
    out = {f"b_{a}": cal.bias_counts[i] for i, a in enumerate(SENSOR_AXES)}
    out.update({f"k_{a}": cal.scale_counts_per_dps[i] for i, a in enumerate(SENSOR_AXES)})
    out.update(cal.nonorthogonality)
    return out


def eight_positions() -> np.ndarray:
    """Turntable positions: level at four headings, then upside down at four headings (rotations body->nav)."""
    rots = [Rotation.from_euler("ZYX", [yaw, 0.0, roll], degrees=True)
            for roll in (0.0, 180.0) for yaw in (0.0, 90.0, 180.0, 270.0)]
    return np.array([r.as_matrix() for r in rots])


def field_in_sensor(rotations: np.ndarray) -> np.ndarray:
    """True field in the sensor frame h = R^T h_nav for each rotation (K, 3), uT."""
    return np.einsum("kji,j->ki", rotations, EARTH_FIELD)


def mag_steps(model: MagErrorModel, h: np.ndarray, rng: np.random.Generator, known: bool = True) -> MagStepMeans:
    sem = np.full(h.shape, MAG_NOISE_UT / np.sqrt(N_MAG))
    mean = model.output_ut(h) + rng.normal(size=h.shape) * sem
    names = tuple(f"p{k}" for k in range(len(h)))
    return MagStepMeans(names, h if known else None, mean, sem, np.full(len(h), N_MAG))


# ------------------------------------------------------------------ gyroscope

def test_gyro_seed_modes_recover_all_twelve_parameters_within_4_sigma():
    model = GyroErrorModel.draw(np.random.default_rng(11))
    steps = gyro_steps(model, np.random.default_rng(12))
    cal = solve_gyro(steps)
    truth = gyro_named_truth(*gyro_truth(model))
    est = gyro_named_estimate(cal)
    assert set(cal.sigma) == set(param_names()) == set(truth)
    for name in param_names():
        assert cal.sigma[name] > 0
        assert abs(est[name] - truth[name]) < 4 * cal.sigma[name], name
    assert cal.n_steps == 18
    assert 0.3 < cal.chi2_per_dof < 2.0
    assert cal.residual_rms_dps < 3 * NOISE_DPS / np.sqrt(N_GYRO)
    # apply() inverts the model: raw counts of a known rate give that rate back
    w = np.array([[10.0, -20.0, 30.0], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(cal.apply(cal.predict_counts(w)), w, atol=1e-9)
    m_true, b_true = gyro_truth(model)
    np.testing.assert_allclose(cal.apply(w @ m_true.T + b_true), w, atol=0.01)


def test_gyro_reported_sigmas_match_the_monte_carlo_scatter():
    model = GyroErrorModel.draw(np.random.default_rng(21))
    truth = gyro_named_truth(*gyro_truth(model))
    rng = np.random.default_rng(22)
    errors = {n: [] for n in param_names()}
    sigmas = {n: [] for n in param_names()}
    for _ in range(200):
        cal = solve_gyro(gyro_steps(model, rng))
        est = gyro_named_estimate(cal)
        for n in param_names():
            errors[n].append(est[n] - truth[n])
            sigmas[n].append(cal.sigma[n])
    for n in param_names():
        ratio = np.std(errors[n]) / np.median(sigmas[n])
        assert 0.85 < ratio < 1.15, f"{n}: scatter/sigma = {ratio:.3f}"
        assert abs(np.mean(errors[n])) < 4 * np.median(sigmas[n]) / np.sqrt(200), f"{n} biased"


def test_gyro_plus_minus_pair_biases_agree_with_the_least_squares_bias():
    model = GyroErrorModel.draw(np.random.default_rng(31))
    cal = solve_gyro(gyro_steps(model, np.random.default_rng(32)))
    assert len(cal.bias_pairs) == 9
    assert sorted((p.axis_spun, p.rate_dps) for p in cal.bias_pairs) == sorted(
        (a, r) for a in SENSOR_AXES for r in (25.0, 40.0, 63.0))
    b_ls = cal.bias_counts
    sig_ls = np.array([cal.sigma[f"b_{a}"] for a in SENSOR_AXES])
    for p in cal.bias_pairs:
        assert np.all(p.sigma_counts > 0)
        tol = 4 * np.sqrt(p.sigma_counts**2 + sig_ls**2)
        assert np.all(np.abs(p.bias_counts - b_ls) < tol), (p.axis_spun, p.rate_dps)
    mean_pair = np.mean([p.bias_counts for p in cal.bias_pairs], axis=0)
    np.testing.assert_allclose(mean_pair, b_ls, atol=float(4 * sig_ls.max()))


def test_gyro_without_rates_about_z_names_z_in_the_observability_error():
    model = GyroErrorModel.draw(np.random.default_rng(41))
    steps = gyro_steps(model, np.random.default_rng(42), axes="xy")
    with pytest.raises(ObservabilityError, match="never spin about z") as err:
        solve_gyro(steps)
    msg = str(err.value)
    for name in ("k_z", "m_xz", "m_yz", "add rate steps about z"):
        assert name in msg


def test_gyro_three_single_direction_rates_are_rank_deficient():
    names, w = ("x", "y", "z"), np.diag([25.0, 40.0, 63.0])
    steps = RateStepMeans(names, w, w * LSB_PER_DPS, np.ones((3, 3)), np.full(3, 1000), LSB_PER_DPS)
    with pytest.raises(ObservabilityError, match="do not determine"):
        solve_gyro(steps)


# ------------------------------------------------------------------ magnetometer

def test_mag_eight_positions_recover_a_and_b_within_4_sigma():
    model = MagErrorModel.draw(np.random.default_rng(51))
    h = field_in_sensor(eight_positions())
    cal = solve_mag_positions(mag_steps(model, h, np.random.default_rng(52)))
    a_true, b_true = np.asarray(model.soft_iron), np.asarray(model.hard_iron_ut)
    assert cal.method == "positions" and cal.n_steps == 8 and cal.field_ut is None
    assert set(cal.sigma) == set(sigma_names())
    for i, a in enumerate(SENSOR_AXES):
        assert abs(cal.hard_iron_ut[i] - b_true[i]) < 4 * cal.sigma[f"hard_iron_{a}"]
        for j, c in enumerate(SENSOR_AXES):
            assert abs(cal.matrix[i, j] - a_true[i, j]) < 4 * cal.sigma[f"a_{a}{c}"], f"a_{a}{c}"
    np.testing.assert_allclose(cal.apply(model.output_ut(h)), h, atol=0.05)


def test_mag_positions_in_one_plane_or_without_poses_are_refused():
    model = MagErrorModel.draw(np.random.default_rng(61))
    level = field_in_sensor(eight_positions()[:4])  # same field z component: fields in one plane
    with pytest.raises(ObservabilityError, match="plane"):
        solve_mag_positions(mag_steps(model, level, np.random.default_rng(62)))
    flat = field_in_sensor(eight_positions())
    flat[:, 2] = 0.0  # directions span only 2D
    with pytest.raises(ObservabilityError, match="not 3D"):
        solve_mag_positions(mag_steps(model, flat, np.random.default_rng(63)))
    with pytest.raises(CalibError, match="field_nominal_ut"):
        solve_mag_positions(mag_steps(model, field_in_sensor(eight_positions()), np.random.default_rng(64),
                                      known=False))


def test_mag_ellipsoid_recovers_hard_iron_and_the_field_up_to_one_rotation():
    model = MagErrorModel.draw(np.random.default_rng(71))
    rots = Rotation.random(30, random_state=np.random.default_rng(72)).as_matrix()
    h = field_in_sensor(rots)
    steps = mag_steps(model, h, np.random.default_rng(73), known=False)
    cal = solve_mag_ellipsoid(steps, FIELD_UT)
    sem = MAG_NOISE_UT / np.sqrt(N_MAG)
    assert cal.method == "ellipsoid" and cal.field_ut == FIELD_UT and cal.n_steps == 30
    b_true = np.asarray(model.hard_iron_ut)
    for i, a in enumerate(SENSOR_AXES):
        assert abs(cal.hard_iron_ut[i] - b_true[i]) < 4 * cal.sigma[f"hard_iron_{a}"]
    corrected = cal.apply(steps.mean_ut)
    norms = np.linalg.norm(corrected, axis=1)
    assert np.all(np.abs(norms - FIELD_UT) < 4 * sem)
    assert cal.fit_quality == pytest.approx(np.sqrt(np.mean((norms - FIELD_UT) ** 2)), rel=1e-9)
    assert cal.residual_rms_ut == cal.fit_quality < 2 * sem
    assert 0.3 < cal.chi2_per_dof < 2.0
    # A_fit^-1 A_true is one rotation: the corrected field is the true field rotated by it
    r = np.linalg.solve(cal.matrix, np.asarray(model.soft_iron))
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=3e-3)
    assert np.linalg.det(r) > 0
    u, _, vt = np.linalg.svd(corrected.T @ h)  # Procrustes: corrected ~ R_best h
    r_best = u @ vt
    assert np.sqrt(np.mean((corrected - h @ r_best.T) ** 2)) < 4 * sem
    assert np.degrees(np.arccos(np.clip((np.trace(r_best.T @ r) - 1) / 2, -1, 1))) < 0.2


def test_mag_ellipsoid_needs_enough_spread_orientations_and_a_positive_field():
    model = MagErrorModel.draw(np.random.default_rng(81))
    rots = Rotation.random(6, random_state=np.random.default_rng(82)).as_matrix()
    steps = mag_steps(model, field_in_sensor(rots), np.random.default_rng(83), known=False)
    with pytest.raises(ObservabilityError):
        solve_mag_ellipsoid(steps, FIELD_UT)
    with pytest.raises(CalibError, match="field_ut"):
        solve_mag_ellipsoid(steps, -50.0)


# ------------------------------------------------------------------ bad inputs

def _valid_rate_kwargs() -> dict:
    names, w = seed_rate_modes()
    return dict(names=names, rate_nominal_dps=w, mean_counts=w * LSB_PER_DPS, sem_counts=np.ones_like(w),
                n_samples=np.full(len(w), N_GYRO), lsb_per_dps=LSB_PER_DPS)


def _valid_mag_kwargs() -> dict:
    h = field_in_sensor(eight_positions())
    return dict(names=tuple("abcdefgh"), field_nominal_ut=h, mean_ut=h.copy(), sem_ut=np.full(h.shape, 0.03),
                n_samples=np.full(8, N_MAG))


def _with(kwargs: dict, key: str, fn) -> dict:
    out = dict(kwargs)
    out[key] = fn(np.array(out[key], float))
    return out


def _nan_at_first(a):
    a = a.copy()
    a.flat[0] = np.nan
    return a


@pytest.mark.parametrize("key,fn,match", [
    ("mean_counts", _nan_at_first, "NaN"),
    ("rate_nominal_dps", _nan_at_first, "NaN"),
    ("mean_counts", lambda a: a[:, :2], "shape"),
    ("rate_nominal_dps", lambda a: a[:-1], "shape"),
    ("sem_counts", lambda a: a * 0.0, "> 0"),
    ("sem_counts", lambda a: -a, "> 0"),
    ("n_samples", lambda a: a[:3], "shape"),
])
def test_rate_step_means_reject_bad_inputs(key, fn, match):
    with pytest.raises(CalibError, match=match) as err:
        RateStepMeans(**_with(_valid_rate_kwargs(), key, fn))
    assert f"RateStepMeans.{key}" in str(err.value)


def test_rate_step_means_reject_a_bad_sensitivity():
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(CalibError, match="lsb_per_dps"):
            RateStepMeans(**{**_valid_rate_kwargs(), "lsb_per_dps": bad})


@pytest.mark.parametrize("key,fn,match", [
    ("mean_ut", _nan_at_first, "NaN"),
    ("field_nominal_ut", _nan_at_first, "NaN"),
    ("mean_ut", lambda a: a.T, "shape"),
    ("field_nominal_ut", lambda a: a[:, :2], "shape"),
    ("sem_ut", lambda a: a * 0.0, "> 0"),
    ("sem_ut", _nan_at_first, "NaN"),
])
def test_mag_step_means_reject_bad_inputs(key, fn, match):
    with pytest.raises(CalibError, match=match) as err:
        MagStepMeans(**_with(_valid_mag_kwargs(), key, fn))
    assert f"MagStepMeans.{key}" in str(err.value)


def _gyro_cal() -> GyroCalibration:
    return solve_gyro(gyro_steps(GyroErrorModel.draw(np.random.default_rng(91)), np.random.default_rng(92)))


def _mag_cals() -> list[MagCalibration]:
    model = MagErrorModel.draw(np.random.default_rng(93))
    pos = solve_mag_positions(mag_steps(model, field_in_sensor(eight_positions()), np.random.default_rng(94)))
    rots = Rotation.random(25, random_state=np.random.default_rng(95)).as_matrix()
    ell = solve_mag_ellipsoid(mag_steps(model, field_in_sensor(rots), np.random.default_rng(96), known=False),
                              FIELD_UT)
    return [pos, ell]


@pytest.mark.parametrize("field_name", ["matrix_counts_per_dps", "bias_counts", "sigma", "bias_pairs", "n_steps"])
def test_gyro_from_dict_names_a_missing_field(field_name):
    d = _gyro_cal().to_dict()
    del d[field_name]
    with pytest.raises(CalibrationFileError, match=field_name):
        GyroCalibration.from_dict(d, path="cal.yaml")


def test_gyro_from_dict_names_wrongly_shaped_or_inconsistent_fields():
    base = _gyro_cal().to_dict()
    cases = [
        ("matrix_counts_per_dps", [[1.0, 0.0], [0.0, 1.0]], r"matrix_counts_per_dps: expected shape \[3, 3\]"),
        ("bias_counts", [1.0, 2.0], r"bias_counts: expected shape \[3\]"),
        ("scale_counts_per_dps", [1.0, 2.0, 3.0], "diagonal"),
        ("lsb_per_dps", "fast", "lsb_per_dps: expected a number"),
    ]
    for key, value, match in cases:
        d = {**base, key: value}
        with pytest.raises(CalibrationFileError, match=match) as err:
            GyroCalibration.from_dict(d, path="cal.yaml")
        assert str(err.value).startswith("cal.yaml: gyro.")
    sigma = dict(base["sigma"])
    del sigma["m_zy"]
    with pytest.raises(CalibrationFileError, match=r"gyro\.sigma\.m_zy"):
        GyroCalibration.from_dict({**base, "sigma": sigma})
    pairs = [dict(p) for p in base["bias_pairs"]]
    pairs[2]["bias_counts"] = [0.0]
    with pytest.raises(CalibrationFileError, match=r"bias_pairs\[2\]\.bias_counts"):
        GyroCalibration.from_dict({**base, "bias_pairs": pairs})
    with pytest.raises(CalibrationFileError, match="unknown"):
        GyroCalibration.from_dict({**base, "extra": 1})


@pytest.mark.parametrize("field_name", ["matrix", "hard_iron_ut", "sigma", "method", "field_ut"])
def test_mag_from_dict_names_a_missing_field(field_name):
    d = _mag_cals()[0].to_dict()
    del d[field_name]
    with pytest.raises(CalibrationFileError, match=field_name):
        MagCalibration.from_dict(d, path="mag.yaml")


def test_mag_from_dict_names_wrongly_shaped_fields():
    base = _mag_cals()[1].to_dict()
    for key, value, match in [("matrix", [1.0, 2.0, 3.0], r"matrix: expected shape \[3, 3\]"),
                              ("hard_iron_ut", [[1.0, 2.0, 3.0]], r"hard_iron_ut: expected shape \[3\]"),
                              ("method", "guess", "method: expected one of"),
                              ("matrix", np.zeros((3, 3)).tolist(), "invertible")]:
        with pytest.raises(CalibrationFileError, match=match):
            MagCalibration.from_dict({**base, key: value}, path="mag.yaml")


# ------------------------------------------------------------------ round trips

def test_gyro_to_dict_from_dict_round_trip_is_exact():
    yaml = pytest.importorskip("yaml")
    cal = _gyro_cal()
    d = cal.to_dict()
    back = GyroCalibration.from_dict(yaml.safe_load(yaml.safe_dump(d)))
    assert back.to_dict() == d
    np.testing.assert_array_equal(back.matrix_counts_per_dps, cal.matrix_counts_per_dps)
    np.testing.assert_array_equal(back.bias_counts, cal.bias_counts)
    assert back.sigma == cal.sigma and back.nonorthogonality == cal.nonorthogonality
    for p, q in zip(back.bias_pairs, cal.bias_pairs):
        np.testing.assert_array_equal(p.bias_counts, q.bias_counts)
        np.testing.assert_array_equal(p.sigma_counts, q.sigma_counts)
    counts = np.random.default_rng(97).normal(0, 3000, (5, 3))
    np.testing.assert_array_equal(back.apply(counts), cal.apply(counts))


def test_mag_to_dict_from_dict_round_trip_is_exact():
    yaml = pytest.importorskip("yaml")
    for cal in _mag_cals():
        d = cal.to_dict()
        back = MagCalibration.from_dict(yaml.safe_load(yaml.safe_dump(d)))
        assert back.to_dict() == d
        np.testing.assert_array_equal(back.matrix, cal.matrix)
        np.testing.assert_array_equal(back.hard_iron_ut, cal.hard_iron_ut)
        assert back.method == cal.method and back.field_ut == cal.field_ut and back.fit_quality == cal.fit_quality
        m = np.random.default_rng(98).normal(0, 50, (5, 3))
        np.testing.assert_array_equal(back.apply(m), cal.apply(m))


def test_step_times_must_match_the_steps_and_durations_be_non_negative():
    kw = _valid_rate_kwargs()
    k = len(kw["names"])
    with pytest.raises(CalibError, match=r"RateStepMeans\.t_s: expected shape"):
        RateStepMeans(**kw, t_s=np.arange(k - 1.0))
    with pytest.raises(CalibError, match=r"RateStepMeans\.duration_s: every duration"):
        RateStepMeans(**kw, t_s=np.arange(k * 1.0), duration_s=np.full(k, -1.0))
    with pytest.raises(CalibError, match=r"MagStepMeans\.t_s: contains NaN"):
        MagStepMeans(**_valid_mag_kwargs(), t_s=np.full(8, np.nan))


def test_the_wander_between_steps_enters_the_gyro_fit_and_the_pair_sigmas():
    """With a stability and step times the fit is GLS with V = diag(sem^2) + lsb^2 W (the bias sigma
    then holds the wander common to the session) and each +/- pair's sigma holds their wander."""
    model = GyroErrorModel.draw(np.random.default_rng(33))
    steps = gyro_steps(model, np.random.default_rng(34))
    k = len(steps)
    stab = BiasStability(0.002, 2e-4, 5000.0, "deg/s")
    timed = RateStepMeans(**{**steps.__dict__, "t_s": 100.0 + 108.0 * np.arange(k), "duration_s": np.full(k, 100.0),
                             "bias_stability": stab})
    plain, wandering = solve_gyro(steps), solve_gyro(timed)
    w = timed.wander_counts2()
    assert w.shape == (k, k) and np.allclose(w, LSB_PER_DPS**2 * stab.cov(timed.t_s, timed.duration_s))
    for a in SENSOR_AXES:
        assert wandering.sigma[f"b_{a}"] > 3 * plain.sigma[f"b_{a}"]
    first = wandering.bias_pairs[0]
    expected = 0.5 * np.sqrt(timed.sem_counts[0] ** 2 + timed.sem_counts[1] ** 2 + w[:2, :2].sum())
    np.testing.assert_allclose(first.sigma_counts, expected)
