"""One map from an effect of the discovery library to the simulator (``calib.discovery.effects``,
``Effect.sim_field``): the simulated rig's ``sim: effects:`` and the digital twin (rig/analysis/twin.py)
both read it; these tests check the one table is complete and that both ends land in the same field."""

from __future__ import annotations

import numpy as np

from calib.accel.result import AccelCalibration
from calib.discovery.effects import LIBRARY
from drivers.sensors.sim.error_model import AccelErrorModel
from rig.analysis import twin
from rig.simulation.settings import EFFECT_FIELDS, EFFECT_PARAMS, WORLD_EFFECTS, AccelOverrides, Effects, SimSettings
from rig.simulation.simrig import SimulatedRig

#: a value of each effect with an error-model field, as a calibration file states it (flat, ``params`` order)
ESTIMATES = {name: (np.arange(1, len(e.params) + 1) * 1e-4 * (-1) ** np.arange(len(e.params))).tolist()
             for name, e in LIBRARY.items() if e.sim_field is not None}


def test_every_library_effect_is_either_an_error_model_field_or_a_world_effect():
    defaults = AccelErrorModel().to_dict()
    for name, e in LIBRARY.items():
        if e.sim_field is None:
            assert name in WORLD_EFFECTS, name
            continue
        assert e.sim_field in defaults, (name, e.sim_field)
        assert np.size(defaults[e.sim_field]) == len(e.params), name  # the same parameters, in the same order
    assert EFFECT_FIELDS == {n: e.sim_field for n, e in LIBRARY.items() if e.sim_field is not None}
    assert set(EFFECT_FIELDS).isdisjoint(WORLD_EFFECTS) and set(EFFECT_FIELDS) | set(WORLD_EFFECTS) == set(LIBRARY)
    assert set(Effects.model_fields) == set(LIBRARY) | set(EFFECT_PARAMS)  # what a rig file may switch on


def test_a_hidden_effect_and_the_twin_of_its_estimate_set_the_same_field_to_the_same_value():
    """A rig file's ``sim: effects:`` puts each value into its field of the simulated sensor; the twin of a
    calibration that estimated the same values writes them into the same fields (at the calibration's own
    reference temperature and time, so nothing is re-expanded)."""
    shapes = {name: np.shape(AccelErrorModel().to_dict()[LIBRARY[name].sim_field]) for name in ESTIMATES}
    hidden = {name: np.reshape(v, shapes[name]).tolist() for name, v in ESTIMATES.items()}
    sim = SimulatedRig(SimSettings(time_scale=0, effects=hidden), seed=5)
    cal = AccelCalibration(
        model="triangular", lsb_per_g=8192.0, bias_counts=[0.0] * 3, scale_counts_per_g=[8192.0] * 3,
        misalignment={"alpha_yz": 0.0, "alpha_zy": 0.0, "alpha_zx": 0.0},
        matrix_counts_per_g=(np.eye(3) * 8192.0).tolist(), temperature=None,
        effects=[{"name": n, "unit": LIBRARY[n].unit, "axes": [], "estimate": v, "sigma": [0.0] * len(v), "t0_c": 25.0,
                  "t_ref_s": 0.0, "band_c": 0.5, "rate_window_s": 5.0, "t_jump_s": 100.0} for n, v in ESTIMATES.items()],
        sigma={"bias_counts": [0.0] * 3, "scale_counts_per_g": [0.0] * 3, "matrix_counts_per_g": np.zeros((3, 3)).tolist()},
        fit={"steps": 30, "samples": 3000, "residual_rms_g": 1e-4, "chi2_per_dof": 1.0})
    errors, _, notes = twin.error_model(cal)
    AccelOverrides(**errors)  # every key is a field the rig file's schema accepts
    assert notes == []
    for name, value in hidden.items():
        field = LIBRARY[name].sim_field
        assert np.allclose(getattr(sim.accel_errors, field), value), name
        assert np.allclose(errors[field], value), name
