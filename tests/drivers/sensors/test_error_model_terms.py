"""The accelerometer's error model (drivers.sensors.sim.error_model): its equation term by term, written out here,
and a coefficient given a new value between two blocks of samples taking effect at the next."""

from __future__ import annotations

import numpy as np

from drivers.sensors.sim.error_model import AccelErrorModel


def _inputs(rng, n=17):
    f = rng.normal(0, 1, (n, 3))
    temp = 25 + rng.normal(0, 5, n)
    t = np.sort(rng.uniform(0, 100, n))
    heating = rng.choice([-1.0, 0.0, 1.0], n)
    return f, temp, t, heating, rng.normal(0, 0.1, n)


def _written_out(m: AccelErrorModel, f, temp, t, heating, rate):
    a = {k: np.asarray(v, float) for k, v in m.to_dict().items() if isinstance(v, list)}
    dt = (temp - m.t_ref_c)[:, None]
    prods = np.stack([f[:, 0] * f[:, 1], f[:, 1] * f[:, 2], f[:, 2] * f[:, 0]], axis=1)
    return ((1 + a["scale_tempco_per_c"] * dt) * (f @ a["matrix"].T) + a["bias_g"] + a["bias_tempco_g_per_c"] * dt
            + a["bias_tempco2_g_per_c2"] * dt**2 + a["bias_drift_g_per_s"] * t[:, None]
            + a["scale_nonlinearity"] * f**2 + prods @ a["cross_axis_nonlinearity"].T
            + 0.5 * a["thermal_hysteresis_g"] * heating[:, None] + a["bias_tempco3_g_per_c3"] * dt**3
            + a["thermal_gradient_g_per_c_per_s"] * rate[:, None] + a["bias_jump_g"] * (t >= m.bias_jump_t_s)[:, None])


def test_every_term_of_the_equation_is_in_the_output():
    rng = np.random.default_rng(3)
    m = AccelErrorModel.draw(rng)
    for name in ("bias_tempco2_g_per_c2", "scale_tempco_per_c", "scale_nonlinearity", "bias_drift_g_per_s",
                 "thermal_hysteresis_g", "bias_tempco3_g_per_c3", "thermal_gradient_g_per_c_per_s", "bias_jump_g"):
        setattr(m, name, rng.normal(0, 1e-3, 3).tolist())
    m.cross_axis_nonlinearity = rng.normal(0, 1e-3, (3, 3)).tolist()
    m.bias_jump_t_s = 50.0
    x = _inputs(rng)
    np.testing.assert_allclose(m.output_g(*x), _written_out(m, *x), rtol=0, atol=1e-12)


def test_a_coefficient_given_a_new_value_takes_effect_at_the_next_block():
    rng = np.random.default_rng(4)
    m = AccelErrorModel.draw(rng)
    x = _inputs(rng)
    before = m.output_g(*x)
    np.testing.assert_allclose(before, _written_out(m, *x), rtol=0, atol=1e-12)
    m.bias_jump_g, m.bias_jump_t_s = [0.01, -0.02, 0.03], 0.0
    m.t_ref_c = 20.0
    after = m.output_g(*x)
    np.testing.assert_allclose(after, _written_out(m, *x), rtol=0, atol=1e-12)
    assert np.abs(after - before).min() > 1e-3
    m.thermal_gradient_g_per_c_per_s = [1e-3, 0.0, 0.0]
    assert m.needs_rate()
