"""What `rig characterize` says of a term its record cannot resolve (docs/noise.md, "The profile"): a floor hidden
behind white noise and walk is fitted above 0 with an interval from 0, and a calibration weighed with the profile
would take its point value; the report says so in one note per axis, and says nothing of the axes it resolves."""

from __future__ import annotations

import math

import numpy as np

from calib.noise.characterize import characterize
from calib.noise.synthetic import noise
from calib.noise.terms import NoiseFigures
from rig.analysis.characterize import unresolved_notes

RATE_HZ = 100.0
FAMILY = NoiseFigures(N=330e-6, B=40e-6, K=4e-6)  # B in the registry's convention (the generator's)


def test_a_hidden_floor_is_noted_with_its_axis_and_interval_and_the_floors_shown_are_not():
    rng = np.random.default_rng(1)
    n = 720_000  # 2 h
    shown = NoiseFigures(N=0.5 * FAMILY.N, B=2.0 * FAMILY.B, K=FAMILY.K)
    hidden = NoiseFigures(N=1.5 * FAMILY.N, B=0.3 * FAMILY.B, K=2.0 * FAMILY.K)
    accel = np.column_stack([noise(f, n, RATE_HZ, rng) for f in (shown, shown, hidden)]) + [0.0, 0.0, 1.0]
    family_floor = NoiseFigures(N=FAMILY.N, B=FAMILY.B / math.sqrt(2), K=FAMILY.K)  # as rig characterize asks
    result = characterize(np.arange(n) / RATE_HZ, {"accel": accel}, RATE_HZ, expected={"accel": family_floor})
    notes = unresolved_notes(result)
    expected = {(axis, term) for axis, fit in result.fits["accel"].items() for term, f in fit.terms.items() if f.lo <= 0}
    assert ("z", "B") in expected  # the hidden floor
    assert ("x", "B") not in expected and ("y", "B") not in expected  # the floors shown
    assert len(notes) == len(expected), notes
    names = {"N": "white noise", "B": "bias instability", "K": "random walk"}
    for axis, term in expected:
        f = result.fits["accel"][axis].terms[term]
        unit = "g" + {"N": "/rtHz", "B": "", "K": "/rts"}[term]
        note = next(n for n in notes if n.startswith(f"accel {axis}: {names[term]} not resolved by this record"))
        assert f"(95 % interval from 0 to {f.hi:.3g} {unit})" in note
        assert (f"takes its point value {f.value:.3g} {unit}" in note) if f.value > 0 else ("takes 0 for it" in note)
