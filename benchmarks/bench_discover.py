"""Discrepancy workflow: detection rate, false alarms, smallest detectable magnitude, run time.

Usage::

    .venv/bin/python benchmarks/bench_discover.py [--seeds 20] [--clean 100] [--full 0] [--sessions 'GLOB']
        [--pvalues] [--no-mdm] [--no-run-time] [--designs a,b] [--effects a,b] [--templates T26 THERMAL]
    .venv/bin/python benchmarks/bench_discover.py --rig-only [--full N --first-seed 100 --full-designs a,b
        --geometry on|off --characterised SEED] [--sessions 'DIR/<procedure>-*'] [--pvalues] [--family-draws 200000]

**Sample-level simulation** (the default, fast): a template session fixes the design (poses, step
times and durations, temperatures, legs, rates, outer-axis angles, samples per step). Each trial
draws a datasheet-class sensor (``AccelErrorModel.draw``), hides an effect at the stated magnitude,
evaluates the simulator's own error equation at every step, and adds the simulator's own ``dlpf``
noise (``drivers.sensors.sim.noise.NoiseProcess``: white noise through the 44 Hz DLPF, flicker and
random walk of the MPU-9150 accelerometer, one continuous process over the whole session) to every
sample; the samples are quantised to counts and reduced to step means and standard errors exactly as
``rig.session.step_means`` does (pooled VIF). Only the turntable and the chamber are not simulated.

Designs: ``tumble26`` and ``thermal`` (templates recorded on the simulated rig, dlpf noise),
``tumble26_1khz`` (the tumble26 template at 1 kHz: ten times the samples per step), ``legs`` (the
issue's design: heating steps at 15, 27.6 and 40 C, cooling steps at 33 and 21 C, six faces each,
the first leg unknown) and ``ramps`` (faces repeated while the chamber heats and cools at up to
0.02 C/s, for ``thermal_gradient``).

**Full simulated rig**: ``--full N`` runs N clean sessions per recorded design (``--full-designs``, default
all four; seeds ``--first-seed`` .. + N - 1) through the emulated turntable and sensor with ``noise: dlpf``
(``--geometry on|off``: the table's own errors, ``sim.geometry.enabled``; default the rig file's: on since
2026-11-26);
``--sessions GLOB`` evaluates already-recorded session directories instead (each glob match is a session's
parent directory, as written by ``rig run --out``, named ``<procedure>-<seed>``: grouped by the procedure);
``--rig-only`` skips everything else. A false alarm is any effect named other than ``bias_tempco`` (which
every drawn sensor has); the verdict's false alarms (``gap_closed: false`` on a clean session) are counted
separately. Each design's row also gives the sessions with a Bonferroni-family event (:func:`naming_pass`:
the smallest candidate p-value at the pass where a spurious name enters, times the candidates, below 0.01),
how many spurious names were *not* such an event (a step of the selection naming on its own: 0 so far), the
mean chi2/dof after, and the true residual's chi2/n against the search's V (:func:`true_residual_chi2`: 1
when V is right). ``--family-draws N``: each design's own family rate when V is right (:func:`family_rate`,
Monte Carlo over whitened noise), what a clean session of that design names at most.

**Calibration of the tests** (``--pvalues``): on the same clean sessions, each candidate's p-value
of the search's test against the baseline plus ``bias_tempco`` (the baseline alone where the search does not
name ``bias_tempco``: six positions) (:func:`calib.discovery.search.candidate_pvalues`, :func:`naming_pass`),
which is uniform when the test is calibrated: the table
gives the counts below 0.001, 0.01 and 0.05 and the Kolmogorov-Smirnov p-value against the uniform,
and how many sessions Bonferroni's family (the smallest p-value times the number of candidates) puts
below 0.01 (what forward selection can name: at most 1 % of sessions).

**The grown hidden-effect matrix** (issue 27 item 5, ``--matrix [--rows i,j]``): designs where effects
alias, each also clean, sample level as above, 20 seeds per cell. ``heat_then_cool``: six faces at 22,
30, 38, 46 C (heating) then 42, 34, 26 C (cooling), the first level's leg unknown to the session (the
sensor was heated to it from 20 C); ``cool_then_heat``: 46, 38, 30, 22 then 26, 34, 42 C from 50 C;
``hand_placed``: six faces placed by hand, four 10 s windows each, no turntable angles (``pose_error``
hidden as a turn of every placement by the magnitude, about a random axis perpendicular to the face).
Outcomes (v6): *named* (the hidden effect alone, + bias_tempco; clean: nothing else), *aliased* (the
hidden effect in an alias group, another used), *weak* (nothing named but bias_tempco, the hidden effect
listed as a weak candidate), *missed* (nothing named but bias_tempco, the hidden effect not listed: below
what the design shows), *wrong* (another name). Then the workflow goes on as ``rig discover --propose``
does (:func:`follow`): the alias pair holding the hidden effect, or (no alias left) every weak candidate
whose experiment reaches power 0.9 within the budget, gets its blocks simulated after the design with the
same sensor (the trial's seed) and the same hidden effect, the whole procedure run again (fresh noise on
every step; ``--merge``: the session's own noise kept on its steps, as v5 did), and the extended session is
discovered again:
*right name after the proposal* counts it named alone; *right name in the end* counts the trials named
directly or after a proposal; on a clean cell a name after a proposal is a false alarm. Every discovery of
the benchmark (the extended ones too) asserts that no named effect has a final-model p-value above the
false-alarm rate (``checked``). Measured 2026-11-26 (v6) on two cores shared with other jobs (load 6-7),
seeds 3000-3019 (clean: 3000-3099 too):

| hidden | design | magnitude | named | aliased | weak | missed | wrong | proposals followed (power >= 0.9) | right name after the proposal | right name in the end | max final-model p of a named effect |
|---|---|---|---|---|---|---|---|---|---|---|---|
| thermal_hysteresis | heat_then_cool | 1.5 mg | 20/20 | 0 | 0 | 0 | 0 | 0 | - | 20/20 | 6e-20 |
| thermal_hysteresis | cool_then_heat | 1.5 mg | 20/20 | 0 | 0 | 0 | 0 | 0 | - | 20/20 | 1e-22 |
| bias_tempco_quadratic | heat_then_cool | 4e-6 g/C^2 | 20/20 | 0 | 0 | 0 | 0 | 0 | - | 20/20 | 9e-11 |
| bias_tempco_quadratic | cool_then_heat | 4e-6 g/C^2 | 20/20 | 0 | 0 | 0 | 0 | 0 | - | 20/20 | 1e-10 |
| bias_tempco_cubic | heat_then_cool | 1e-6 g/C^3 | 20/20 | 0 | 0 | 0 | 0 | 0 | - | 20/20 | 1e-22 |
| bias_jump at the leg switch | heat_then_cool | 1.5 mg | 0/20 | 20 (as thermal_hysteresis) | 0 | 0 | 0 | 20 (20/20, min 1.000) | 20/20 | 20/20 | 2e-20 |
| bias_jump at a level change (heating leg) | heat_then_cool | 1.5 mg | 20/20 | 0 | 0 | 0 | 0 | 0 | - | 20/20 | 6e-20 |
| bias_jump within a level | heat_then_cool | 1.5 mg | 20/20 | 0 | 0 | 0 | 0 | 0 | - | 20/20 | 8e-60 |
| pose_error | hand_placed | 5 deg | 20/20 | 0 | 0 | 0 | 0 | 0 | - | 20/20 | 0 |
| pose_error | hand_placed | 0.5 deg | 20/20 | 0 | 0 | 0 | 0 | 0 | - | 20/20 | 0 |
| pose_error | hand_placed | 0.1 deg | 20/20 | 0 | 0 | 0 | 0 | 0 | - | 20/20 | 1e-130 |
| thermal_hysteresis (weak: 0.6 x the MDM) | heat_then_cool | 0.5 mg | 17/20 | 2 | 1 | 0 | 0 | 3 (3/3, min 0.930) | 3/3 | **20/20** | 6.4e-4 |
| bias_tempco_quadratic (weak: 0.4 x the MDM) | heat_then_cool | 1.5e-6 g/C^2 | 7/20 | 0 | 8 | 5 | 0 | 8 (8/8, min 0.902) | 7/8 (merge 8/8) | **14/20** (merge 15/20) | 9.4e-4 |
| clean | heat_then_cool | - | 20/20 | 0 | - | - | 0 | 2 (2/2, min 0.906) | 0 false alarms in 2 | 20/20 | - |
| clean | cool_then_heat | - | 20/20 | 0 | - | - | 0 | 2 (2/2, min 0.911) | 0 false alarms in 2 | 20/20 | - |
| clean | hand_placed | - | 20/20 | 0 | - | - | 0 | 2 (2/2, min 0.910) | 0 false alarms in 2 | 20/20 | - |
| clean, seeds 3000-3099 | heat_then_cool | - | 98/100 | 0 | - | - | 2 | 16 (16/16, min 0.902) | 0 false alarms in 16 (merge: 1) | 98/100 (merge 97/100) | 4.8e-4 |
| clean, seeds 3000-3099 | cool_then_heat | - | 98/100 | 0 | - | - | 2 | 16 (16/16, min 0.902) | 0 false alarms in 16 (merge: 1) | 98/100 (merge 97/100) | 4.5e-4 |
| clean, seeds 3000-3099 | hand_placed | - | 99/100 | 0 | - | - | 1 | 5 (5/5, min 0.910) | 0 false alarms in 5 | 99/100 | 1e-3 |

Against the issue's targets: every cell at its stated magnitude names the right effect in 20/20, or (the
jump at the leg switch, exactly aliased with hysteresis on this design) reports the alias with a
proposal of predicted power >= 0.9 in 20/20 that names the jump after it is run in 20/20. The weak
hysteresis now meets it: 17/20 named, the 2 aliased and the 1 weak each get a proposal of power >= 0.93
that names it (20/20 in the end; v5: 19/20, one alias proposal of power 0.84 within 4 blocks). The weak
quadratic does not: 7 named, 8 weak whose proposals (power >= 0.90) name it 7/8, 5 missed (their
p-value times the candidates 0.22-3: no sign of it at 0.4 x the design's minimum detectable magnitude,
3.75e-6 g/C^2): 14/20 in the end (v5: 7/20). No wrong name in a hidden-effect cell; the largest
final-model p-value of a named effect over every run is 1.0e-3 (< 0.01, asserted). Clean: about 1
in 6 sessions gets a weak proposal (16/100; 5/100 hand-placed); running them again named nothing (0 in 16),
merging them added one false alarm (seed 3076's weak ``full_misalignment``, p x candidates 0.0101 in the
session, named in the merged one: a second look at the same data); the
two mirrored thermal designs share seeds and sensors, so their rows are one event, not two.

Clean full-rig false alarms (``--rig-only``, measured 2026-11-26 on two shared cores; docs/discrepancy.md,
"Clean full-rig false alarms re-measured"): thermal_ramp seeds 100-399, ``sim.geometry`` off, 5/300 (100-199:
3/100, 200-399: 2/200), every one a Bonferroni-family event (none beyond), true residual chi2/n 1.005 +- 0.007,
the design's own family rate 0.92 % (``--family-draws 200000``); six_position seeds 100-199 2/100 (its rate
0.65 %); thermal_ramp 100-199 with ``--geometry on`` 1/100 (the pose candidates' p-values then conservative).
With ``--geometry on`` (today's default; docs/discrepancy.md, "With the table's own errors on"), seeds 100-139:
six_position, tumble26 and thermal 0/40 each, no Bonferroni-family event, the designs' own family rates 0.68 %,
0.87 % and 0.94 % (``--family-draws 50000``), the pose candidates' null p-values conservative.
"""

from __future__ import annotations

import argparse
import glob
from dataclasses import replace
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from scipy import stats

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from calib.accel.inputs import StepMeans  # noqa: E402
from calib.numerics.stability import BiasStability  # noqa: E402
from calib.discovery.search import StepContext, candidate_pvalues, discover, final_problem, remaining  # noqa: E402
from calib.discovery.problem import SCATTER_LEVEL, floored_sf  # noqa: E402
from calib.numerics.design import misfit  # noqa: E402
from calib.discovery.effects import heating_state  # noqa: E402
from calib.discovery.problem import pose_blocks  # noqa: E402
from calib.discovery.propose import POWER_TARGET, block_inputs, deciding, separating  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402
from calib.numerics.uncertainty import step_standard_errors  # noqa: E402
from drivers.sensors.chips import CHIPS  # noqa: E402
from drivers.sensors.sim.error_model import AccelErrorModel  # noqa: E402
from drivers.sensors.sim.noise import NoiseProcess  # noqa: E402
from rig.analysis.discover import discover_session, judged_with_rig, step_context  # noqa: E402
from rig.session import load_session, step_means  # noqa: E402

BANDWIDTH_HZ = 44.0
LSB = 8192.0
CHIP = CHIPS["MPU-9150"]
STABILITY = BiasStability(CHIP.accel_bias_instability_g, CHIP.accel_random_walk_g_per_rts, CHIP.accel_flicker_corner_s)

#: (effect, design) -> (error-model field, pattern, stated magnitude); hidden value = pattern * magnitude
CELLS = {
    ("bias_tempco_cubic", "thermal"): ("bias_tempco3_g_per_c3", [1, -1, 1], 2e-7),
    ("bias_tempco_cubic", "legs"): ("bias_tempco3_g_per_c3", [1, -1, 1], 2e-6),
    ("thermal_gradient", "ramps"): ("thermal_gradient_g_per_c_per_s", [1, -1, 1], 0.05),
    ("bias_jump", "tumble26"): ("bias_jump_g", [1, -1, 1], 1e-3),
    ("bias_jump", "thermal"): ("bias_jump_g", [1, -1, 1], 1e-3),
    ("thermal_hysteresis", "legs"): ("thermal_hysteresis_g", [1, 1, -1], 1.5e-3),
    ("thermal_hysteresis", "tumble26"): ("thermal_hysteresis_g", [1, 1, -1], 1.5e-3),
    ("bias_drift", "tumble26"): ("bias_drift_g_per_s", [1, 1, 1], 5e-7),
    ("scale_tempco", "tumble26"): ("scale_tempco_per_c", [1, 1, 1], 2e-4),
    ("scale_nonlinearity", "tumble26"): ("scale_nonlinearity", [1, 1, 1], 3e-3),
}
#: the procedures ``--full`` records
FULL_DESIGNS = ("tumble26", "thermal", "six_position", "thermal_ramp")
FACTORS = (0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0)


class Design:
    """What a trial needs of a session: poses, times, durations, temperatures, legs, rates, angles."""

    def __init__(self, f, temp, t_mid, dur, n, heating, rate, angles, names=None, true_heating=None) -> None:
        self.f, self.temp, self.t_mid, self.dur, self.n = f, temp, t_mid, dur, np.asarray(n, int)
        self.heating, self.rate, self.angles = heating, rate, angles
        self.names = names if names is not None else tuple(f"s{i}" for i in range(len(f)))
        self.true_heating = heating if true_heating is None else true_heating  # what the sensor went through

    def extended(self, x) -> "Design":
        """This design with the steps of ``x`` (:func:`calib.discovery.propose.block_inputs`) appended, their
        legs known to the session and lived by the sensor."""
        k = len(x.f_g)
        return Design(np.vstack([self.f, x.f_g]), np.concatenate([self.temp, x.temp_c]),
                      np.concatenate([self.t_mid, x.t_s]), np.concatenate([self.dur, np.full(k, np.median(self.dur))]),
                      np.concatenate([self.n, np.full(k, int(np.median(self.n)))]),
                      np.concatenate([self.heating, x.heating]), np.concatenate([self.rate, np.zeros(k)]),
                      None if self.angles is None else np.vstack([self.angles, np.zeros((k, 3))]),
                      true_heating=np.concatenate([self.true_heating, x.heating]))

    def true_force(self, rng, field, value) -> np.ndarray:
        """The specific force the sensor feels: the nominal poses, or (``pose_error_deg``) each placement
        (run of consecutive steps at one pose) turned by ``value[0]`` deg about a random perpendicular axis."""
        if field != POSE_ERROR:
            return self.f
        out = np.array(self.f, float)
        for b in np.unique(pose_blocks(self.f, self.t_mid)):
            rows = pose_blocks(self.f, self.t_mid) == b
            face = self.f[rows][0]
            axis = rng.standard_normal(3)
            axis -= (axis @ face) * face
            out[rows] = Rotation.from_rotvec(np.radians(value[0]) * axis / np.linalg.norm(axis)).apply(self.f[rows])
        return out

    @classmethod
    def from_session(cls, path, rate_factor: int = 1) -> "Design":
        s = load_session(path)
        idx = s.static_step_indices()
        st, ctx = step_means(s, idx), step_context(s, idx)
        k = len(st)
        return cls(np.asarray(st.f_nominal_g, float), np.asarray(st.temp_c, float), np.asarray(st.t_s, float),
                   st.duration_s, np.asarray(st.n_samples) * rate_factor, ctx.heating,
                   ctx.temp_rate if ctx.temp_rate is not None else np.zeros(k), ctx.angles_deg, st.names)

    def session(self, rng, field=None, value=None, jump_t_s=None, noise_seed=None):
        """(step means, context, drawn error model) of one simulated session with ``field`` = ``value`` hidden;
        ``noise_seed``: the noise drawn from it instead of from ``rng`` (the same sensor, fresh noise: the
        procedure run again)."""
        m = AccelErrorModel.draw(rng)
        m.t_ref_c = float(np.mean(self.temp))
        if field and field != POSE_ERROR:
            setattr(m, field, list(value))
        if jump_t_s is not None:
            m.bias_jump_t_s = jump_t_s
        out = m.output_g(self.true_force(rng, field, value), self.temp, self.t_mid, self.true_heating, self.rate)
        seed = rng.integers(2**62)
        proc = NoiseProcess([STABILITY.bias_instability] * 3, [STABILITY.random_walk_per_rts] * 3,
                            np.random.default_rng(seed if noise_seed is None else noise_seed),
                            flicker_band_s=(0.02, CHIP.accel_flicker_corner_s))
        times = [np.linspace(t - d / 2, t + d / 2, n) for t, d, n in zip(self.t_mid, self.dur, self.n)]
        noise = proc.sample(np.concatenate(times), np.asarray(m.noise_density_g_per_rthz, float), BANDWIDTH_HZ)
        blocks = np.split(np.round((np.repeat(out, self.n, axis=0) + noise) * LSB), np.cumsum(self.n)[:-1])
        sems, _ = step_standard_errors(blocks, 1 / np.sqrt(12.0))
        steps = StepMeans(names=self.names, f_nominal_g=self.f, mean_counts=np.array([b.mean(axis=0) for b in blocks]),
                          sem_counts=sems, n_samples=self.n, temp_c=self.temp, t_s=self.t_mid, lsb_per_g=LSB,
                          bias_stability=STABILITY, duration_s=self.dur)
        ctx = StepContext(heating=self.heating, temp_rate=self.rate, angles_deg=self.angles)
        return steps, ctx, m

    def trial(self, rng, field=None, value=None, jump_t_s=None):
        """Discover on one simulated session of this design with ``field`` = ``value`` hidden. Asserts the
        issue-27 target on every trial: no named effect has a final-model p-value above the false-alarm rate."""
        steps, ctx, m = self.session(rng, field, value, jump_t_s)
        return checked(discover(steps, ctx)), m


def legs_design() -> Design:
    faces = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    levels = (15.0, 27.6, 40.0, 33.0, 21.0)
    f = np.tile(faces, (len(levels), 1))
    k = len(f)
    temp = np.repeat(levels, 6) + 0.02 * np.random.default_rng(0).standard_normal(k)
    t = 300.0 + np.arange(k) * 30.0 + np.repeat(np.arange(len(levels)) * 900.0, 6)
    return Design(f, temp, t, np.full(k, 5.0), np.full(k, 500), heating_state(temp, 0.5), np.zeros(k),
                  np.zeros((k, 3)))


def ramps_design(reps: int = 10) -> Design:
    faces = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    f = np.tile(faces, (reps, 1))
    k = len(f)
    t = 60.0 + np.arange(k) * 20.0
    rate = 0.02 * np.sin(2 * np.pi * t / (k * 20.0 / 2.3))
    temp = 25.0 + np.cumsum(rate) * 20.0
    return Design(f, temp, t, np.full(k, 5.0), np.full(k, 500), heating_state(temp, 0.5), rate, np.zeros((k, 3)))


FACES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
POSE_ERROR = "pose_error_deg"  # not an error-model field: each placement turned by this angle (Design.true_force)


def two_legs_design(levels, start_c: float) -> Design:
    """Six faces at each chamber level, one leg then the other (both directions: pass the levels in
    order); the session has no record of how the chamber reached the first level (h = 0 there), the
    sensor was brought to it from ``start_c``."""
    f = np.tile(FACES, (len(levels), 1))
    k = len(f)
    temp = np.repeat(levels, 6) + 0.02 * np.random.default_rng(0).standard_normal(k)
    t = 300.0 + np.arange(k) * 30.0 + np.repeat(np.arange(len(levels)) * 900.0, 6)
    true = heating_state(np.concatenate([[start_c], temp]), 0.5)[1:]
    return Design(f, temp, t, np.full(k, 5.0), np.full(k, 500), heating_state(temp, 0.5), np.zeros(k),
                  np.zeros((k, 3)), true_heating=true)


def hand_placed_design(windows: int = 4) -> Design:
    """Six faces placed by hand, each recorded as ``windows`` consecutive 10 s windows; no turntable angles."""
    f = np.repeat(FACES, windows, axis=0)
    k = len(f)
    t = 5.0 + np.arange(k) * 10.0 + np.repeat(np.arange(6) * 20.0, windows)
    temp = 25.0 + 0.01 * np.random.default_rng(0).standard_normal(k)
    return Design(f, temp, t, np.full(k, 10.0), np.full(k, 1000), np.zeros(k), np.zeros(k), None)


def _switch(d: Design) -> float:
    """The leg switch: between the last heating and the first cooling step (or the reverse), s."""
    i = int(np.flatnonzero(d.heating[1:] * d.heating[:-1] < 0)[0]) + 1
    return 0.5 * (d.t_mid[i - 1] + d.t_mid[i])


#: the grown matrix (issue 27 item 5): (label, design, field, pattern, magnitude, expected name, jump time(design))
MATRIX = [
    ("hysteresis", "heat_then_cool", "thermal_hysteresis_g", [1, 1, -1], 1.5e-3, "thermal_hysteresis", None),
    ("hysteresis", "cool_then_heat", "thermal_hysteresis_g", [1, 1, -1], 1.5e-3, "thermal_hysteresis", None),
    ("quadratic tempco", "heat_then_cool", "bias_tempco2_g_per_c2", [1, -1, 1], 4e-6, "bias_tempco_quadratic", None),
    ("quadratic tempco", "cool_then_heat", "bias_tempco2_g_per_c2", [1, -1, 1], 4e-6, "bias_tempco_quadratic", None),
    ("cubic tempco", "heat_then_cool", "bias_tempco3_g_per_c3", [1, -1, 1], 1e-6, "bias_tempco_cubic", None),
    ("jump at the leg switch", "heat_then_cool", "bias_jump_g", [1, -1, 1], 1.5e-3, "bias_jump", _switch),
    ("jump at a level change", "heat_then_cool", "bias_jump_g", [1, -1, 1], 1.5e-3, "bias_jump",
     lambda d: 0.5 * (d.t_mid[11] + d.t_mid[12])),
    ("jump within a level", "heat_then_cool", "bias_jump_g", [1, -1, 1], 1.5e-3, "bias_jump",
     lambda d: 0.5 * (d.t_mid[8] + d.t_mid[9])),
    ("pose error 5 deg", "hand_placed", POSE_ERROR, [1, 0, 0], 5.0, "pose_error", None),
    ("pose error 0.5 deg", "hand_placed", POSE_ERROR, [1, 0, 0], 0.5, "pose_error", None),
    ("weak hysteresis", "heat_then_cool", "thermal_hysteresis_g", [1, 1, -1], 5e-4, "thermal_hysteresis", None),
    ("weak quadratic tempco", "heat_then_cool", "bias_tempco2_g_per_c2", [1, -1, 1], 1.5e-6, "bias_tempco_quadratic",
     None),
    ("pose error 0.1 deg", "hand_placed", POSE_ERROR, [1, 0, 0], 0.1, "pose_error", None),
    ("clean", "heat_then_cool", None, None, 0, None, None),
    ("clean", "cool_then_heat", None, None, 0, None, None),
    ("clean", "hand_placed", None, None, 0, None, None),
]
MATRIX_DESIGNS = {"heat_then_cool": lambda: two_legs_design((22.0, 30.0, 38.0, 46.0, 42.0, 34.0, 26.0), 20.0),
                  "cool_then_heat": lambda: two_legs_design((46.0, 38.0, 30.0, 22.0, 26.0, 34.0, 42.0), 50.0),
                  "hand_placed": hand_placed_design}


def classify(d, expected: str | None) -> str:
    """``named`` (the hidden effect named, nothing else but bias_tempco; clean: nothing but bias_tempco),
    ``aliased`` (named one of an alias group holding it, nothing else), ``weak`` (nothing named but
    bias_tempco, the hidden effect listed as a weak candidate), ``missed`` (nothing named but bias_tempco,
    the hidden effect not among the weak candidates: below what the design shows), ``wrong`` (another name)."""
    names = {e.name for e in d.effects} - {"bias_tempco"}
    if expected is None:
        return "named" if not names else "wrong"
    if names == {expected}:
        return "named"
    if not names:
        return "weak" if any(w["name"] == expected for w in d.weak) else "missed"
    group = next((g for g in d.aliases if expected in g and g[0] in names), None)
    return "aliased" if group is not None and names == {group[0]} else "wrong"


def matrix_cell(row, seeds: int, base_seed: int = 3000) -> dict:
    """One cell over ``seeds`` trials: counts of each outcome (:func:`classify`), the proposals made and
    followed (:func:`follow`), the outcome after them, the largest final-model p-value of a named effect, the
    seconds per trial."""
    label, design_name, field, pattern, mag, expected, jump = row
    design = MATRIX_DESIGNS[design_name]()
    value = None if field is None else np.asarray(pattern, float) * mag
    out = {"named": 0, "aliased": 0, "weak": 0, "missed": 0, "wrong": 0, "max_p": None, "wrong_names": [],
           "followed": 0, "powerful": 0, "power": [], "after": 0, "after_wrong": [], "unreached": 0, "right": 0}
    t0 = time.perf_counter()
    for s in range(seeds):
        jump_t = jump(design) if jump else None
        steps, ctx, _ = design.session(np.random.default_rng(base_seed + s), field, value, jump_t)
        d = checked(discover(steps, ctx))
        kind = classify(d, expected)
        out[kind] += 1
        out["max_p"] = max([out["max_p"] or 0.0] + [e.p_value for e in d.effects]) if d.effects else out["max_p"]
        if kind == "wrong":
            out["wrong_names"].append([e.name for e in d.effects])
        right = kind == "named"
        if kind != "wrong" and not (kind == "named" and expected is not None):
            f = follow(design, steps, ctx, d, expected, (base_seed + s, field, value, jump_t))
            out["unreached"] += f["unreached"]
            if f["followed"]:
                out["followed"] += 1
                out["powerful"] += f["power"] >= POWER_TARGET
                out["power"].append(f["power"])
                out["after"] += f["after"] == "named"
                out["max_p"] = max([out["max_p"] or 0.0] + f["p_after"]) if f["p_after"] else out["max_p"]
                right = f["after"] == "named"
                if f["after"] != "named":
                    out["after_wrong"].append(f["names_after"])
        out["right"] += right
    out["s_per_trial"] = (time.perf_counter() - t0) / seeds
    return out


def checked(d):
    """The issue-27 target, asserted on every discovery of the benchmark: no named effect has a final-model
    p-value above the false-alarm rate."""
    assert all(e.p_value <= d.false_alarm for e in d.effects), [(e.name, e.p_value) for e in d.effects]
    return d


#: the extended session's noise seed is the trial's plus this (the proposed procedure run again: fresh noise
#: on every step, the same sensor); ``--merge``: the session's own noise on its steps (v5 did this)
RERUN_NOISE_SEED = 10**9
MERGE = False


def follow(design: Design, steps, ctx, d, expected: str | None, trial) -> dict:
    """The workflow after a discovery: the proposals ``rig discover --propose`` writes (the alias pair holding
    ``expected``; with no alias left, every weak candidate whose experiment reaches the power target within the
    budget), their
    blocks simulated after the design with the same sensor (the trial's seed) and the same hidden effect, the
    whole procedure run again (fresh noise; :data:`MERGE`: the session's noise kept), and the discovery of the
    extended session: ``followed`` (a proposal was made), ``power`` (the smallest predicted
    power of the proposals followed), ``after`` (:func:`classify` of the extended session), ``names_after``,
    ``unreached`` (weak candidates whose experiment does not reach the power within the budget)."""
    seed, field, value, jump_t = trial
    named = [e.name for e in d.effects]
    props = [p for p in separating(steps, ctx, d, d.false_alarm) if expected is not None and p.pair[1] == expected]
    weak = [] if any(g[0] in named for g in d.aliases) else deciding(steps, ctx, d, d.false_alarm)
    props += [p for p in weak if p.reached]
    unreached = sum(not p.reached for p in weak)
    if not props:
        return {"followed": False, "unreached": unreached}
    prob, _ = final_problem(steps, ctx, named, d.false_alarm)
    poses = np.unique(np.round(prob.f, 6), axis=0)
    setpoints = [sp for p in props for sp in p.setpoints_c]
    x, _ = block_inputs(prob, steps, ctx, setpoints, poses, float(np.median(np.diff(np.sort(steps.t_s)))))
    more, ctx2, _ = design.extended(x).session(np.random.default_rng(seed), field, value, jump_t,
                                               noise_seed=None if MERGE else seed + RERUN_NOISE_SEED)
    d2 = checked(discover(more, ctx2))
    return {"followed": True, "power": min(p.power for p in props), "after": classify(d2, expected),
            "names_after": [e.name for e in d2.effects], "p_after": [e.p_value for e in d2.effects],
            "unreached": unreached}


def print_matrix(seeds: int, rows: str | None = None) -> None:
    print(f"\nthe grown hidden-effect matrix ({seeds} seeds per cell; named = the right name alone (+ bias_tempco), "
          "aliased = in an alias group with the name used, weak = not named, listed as a weak candidate; a proposal "
          "is followed when rig discover --propose writes one: an alias pair holding the hidden effect, a weak "
          "candidate whose experiment reaches power 0.9 within its budget):")
    print("| hidden | design | magnitude | named | aliased | weak | missed | wrong | proposals followed (power >= 0.9) "
          "| right name after the proposal | right name in the end | weak: no experiment within budget "
          "| max final-model p of a named effect | s/trial |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for i, row in enumerate(MATRIX):
        if rows and str(i) not in rows.split(","):
            continue
        c = matrix_cell(row, seeds)
        fo = c["followed"]
        prop = (f"{fo} ({c['powerful']}/{fo}, min {min(c['power']):.3f})", f"{c['after']}/{fo}") if fo else ("0", "-")
        if row[5] is None and fo:  # clean: what is named after following a proposal is a false alarm
            prop = (prop[0], f"{fo - c['after']} false alarm(s) in {fo}")
        max_p = "-" if c["max_p"] is None else f"{c['max_p']:.2g}"
        print(f"| {row[0]} | {row[1]} | {row[4]:g} | {c['named']}/{seeds} | {c['aliased']} | {c['weak']} "
              f"| {c['missed']} | {c['wrong']} | {prop[0]} | {prop[1]} | {c['right']}/{seeds} | {c['unreached']} "
              f"| {max_p} | {c['s_per_trial']:.2f} |"
              + (f" wrong: {c['wrong_names'][:3]}" if c["wrong"] else "")
              + (f" after: {c['after_wrong'][:3]}" if c["after_wrong"] else ""), flush=True)


def rig_path(tmp: Path, geometry: bool | None) -> Path:
    """The rig file :func:`record` writes for ``geometry`` (None: the rig file's default)."""
    return tmp / ("rig.yaml" if geometry is None else f"rig-geometry-{'on' if geometry else 'off'}.yaml")


def record(tmp: Path, procedure: str, seed: int, noise: str = "dlpf", geometry: bool | None = None) -> Path:
    """Run ``procedure`` on the simulated rig (rigs/sim.yaml in virtual time, ``noise``) with ``seed``; ``geometry``
    True or False sets ``sim.geometry.enabled`` (the table's own errors), None leaves the rig file's default."""
    doc = yaml.safe_load((REPO / "rigs" / "sim.yaml").read_text())
    doc["sim"]["time_scale"] = 0
    doc["sim"]["noise"] = noise
    if geometry is not None:
        doc["sim"]["geometry"] = {**doc["sim"].get("geometry", {}), "enabled": bool(geometry)}
    rig = rig_path(tmp, geometry)
    rig.write_text(yaml.safe_dump(doc))
    out = tmp / f"{Path(procedure).stem}-{seed}"
    subprocess.run([sys.executable, "-m", "rig.cli", "run", str(REPO / "procedures" / procedure), "--rig", str(rig),
                    "--out", str(out), "--seed", str(seed), "--quiet", "--yes"], cwd=REPO, check=True, capture_output=True)
    return next(p for p in out.iterdir() if p.is_dir())


def characterise_rig(tmp: Path, seed: int, geometry: bool | None = None) -> Path:
    """Characterise the rig file :func:`record` writes (``geometry`` as there) by reversal: run
    ``procedures/characterize_reversal.yaml`` on it with ``seed``, then ``rig characterize-rig``, which stores the
    record next to the rig file; every session :func:`record` makes on it afterwards is judged characterised (its
    rig file unchanged, docs/uncertainty.md). Returns the record's path."""
    session = record(tmp, "characterize_reversal.yaml", seed, geometry=geometry)
    subprocess.run([sys.executable, "-m", "rig.cli", "characterize-rig", str(session)], cwd=REPO, check=True,
                   capture_output=True)
    rig = rig_path(tmp, geometry)
    return rig.with_name(f"{rig.stem}.characterisation.yaml")


def spurious(d) -> bool:
    return any(e.name != "bias_tempco" for e in d.effects)


def detection(design: Design, cell, factor: float, seeds: int, base_seed: int = 1000) -> tuple[int, int, int]:
    """(named, named alone (+ bias_tempco), within 3 sigma) over ``seeds`` trials at ``factor`` x the magnitude."""
    effect, _ = cell
    field, pattern, mag = CELLS[cell]
    value = np.asarray(pattern, float) * mag * factor
    jump_t = float(np.median(design.t_mid)) + 7.0 if effect == "bias_jump" else None
    det = alone = within = 0
    for s in range(seeds):
        d, _ = design.trial(np.random.default_rng(base_seed + s), field, value, jump_t)
        names = [e.name for e in d.effects]
        if effect in names:
            det += 1
            alone += set(names) <= {effect, "bias_tempco"}
            e = d.effects[names.index(effect)]
            within += bool(np.all(np.abs(np.array(e.estimate) - value) < 3 * np.array(e.sigma)))
    return det, alone, within


def smallest_detected(design: Design, cell, seeds: int) -> float | None:
    """Smallest magnitude on the FACTORS grid named in >= 95 % of ``seeds`` (bisection; monotone assumed)."""
    lo, hi = 0, len(FACTORS) - 1
    if detection(design, cell, FACTORS[hi], seeds, 2000)[0] < 0.95 * seeds:
        return None
    while lo < hi:
        mid = (lo + hi) // 2
        if detection(design, cell, FACTORS[mid], seeds, 2000)[0] >= 0.95 * seeds:
            hi = mid
        else:
            lo = mid + 1
    return FACTORS[lo] * CELLS[cell][2]


def clean_rates(design: Design, n: int) -> tuple[int, int, float]:
    """(spurious names, verdict false alarms, mean chi2/dof after) over ``n`` clean trials."""
    fa = gap = 0
    chi = []
    for s in range(n):
        d, _ = design.trial(np.random.default_rng(5000 + s))
        fa += spurious(d)
        gap += not d.gap_closed
        chi.append(d.chi2_per_dof_after)
    return fa, gap, float(np.mean(chi))


def full_rig(paths) -> tuple[list, int, list, float]:
    """(spurious or not per session, verdict false alarms, names (seed), mean chi2/dof after) over recorded clean
    sessions."""
    gap = 0
    flags, names, chi = [], [], []
    for p in paths:
        s, d = discover_session(p)
        flags.append(spurious(d))
        gap += not d.gap_closed
        chi.append(d.chi2_per_dof_after)
        if spurious(d):
            names.append(([e.name for e in d.effects if e.name != "bias_tempco"], s.info.seed))
    return flags, gap, names, float(np.mean(chi))


def true_residual_chi2(path) -> float | None:
    """The generalised chi-square per step-mean component of a recorded simulated session's *true* residual: the
    step means less the simulator's own noise-free output (its ``sim_truth.yaml``, at the nominal poses, on a
    characterised rig where its characterisation puts them, and the steps' mean temperatures), whitened by the
    search's covariance V (noise, wander, and the rig's errors when discover judges with them). 1 on average when V
    is right (no parameter is fitted); None without a truth."""
    truth = Path(path) / "sim_truth.yaml"
    if not truth.exists():
        return None
    s = load_session(path)
    idx = s.static_step_indices()
    st, rig_cov = judged_with_rig(s, step_means(s, idx), idx)  # a characterised rig's poses corrected
    ctx = replace(step_context(s, idx), rig_cov_counts2=rig_cov)
    model = AccelErrorModel.from_dict(yaml.safe_load(truth.read_text())["accelerometer"])
    out_g = model.output_g(np.asarray(st.f_nominal_g, float), np.asarray(st.temp_c, float), np.asarray(st.t_s, float),
                           np.zeros(len(st)))
    prob, _ = final_problem(st, ctx, [])
    white = prob.whiten((np.asarray(st.mean_counts, float) - out_g * st.lsb_per_g).T.ravel())
    return float(white @ white / len(white))


def naming_pass(steps, ctx, false_alarm: float = 0.01) -> tuple[dict, int]:
    """The candidates' null p-values at the forward pass where a spurious name would enter a clean session, and
    the number of candidates that pass's Bonferroni threshold divides ``false_alarm`` by: against the baseline
    plus the sensor's real ``bias_tempco`` when the search names it first (its p-value below the first pass's
    threshold: every thermal design), against the baseline alone otherwise (a six-position session's few
    millikelvin cannot show it), ``bias_tempco`` itself left out (never counted as a false alarm). A clean
    session names a spurious effect exactly when the smallest of these times that number is below
    ``false_alarm`` (Bonferroni's family), unless a later step of the selection adds a name of its own."""
    base = candidate_pvalues(steps, ctx, model=())
    if held_model(base, false_alarm):
        held = candidate_pvalues(steps, ctx)
        return held, len(held)
    return {k: v for k, v in base.items() if k != "bias_tempco"}, len(base)


def held_model(base_pvalues: dict, false_alarm: float = 0.01) -> list:
    """``["bias_tempco"]`` when the first forward pass names it (its p-value against the baseline alone,
    ``base_pvalues``, times the candidates below ``false_alarm``), else ``[]``."""
    return ["bias_tempco"] if base_pvalues.get("bias_tempco", 1.0) * len(base_pvalues) < false_alarm else []


def _steps_and_context(path):
    """A recorded session's static step means and the context ``rig discover`` gives them (the rig's errors; on a
    characterised rig the step means at the corrected poses, :func:`rig.analysis.discover.judged_with_rig`)."""
    s = load_session(path)
    idx = s.static_step_indices()
    st, rig_cov = judged_with_rig(s, step_means(s, idx), idx)
    return st, replace(step_context(s, idx), rig_cov_counts2=rig_cov)


def session_pvalues(paths) -> list[tuple[dict, int]]:
    """Per recorded clean session: :func:`naming_pass`, with the covariance ``rig discover`` judges against (the
    rig's errors included when it has them)."""
    return [naming_pass(*_steps_and_context(p)) for p in paths]


def family_rate(steps, ctx, held: list, draws: int, seed: int = 1, chunk: int = 20000) -> tuple[float, float, dict]:
    """The design's own false-alarm rate of the forward pass holding ``held``: the probability that the smallest
    candidate p-value of the search's test (:func:`calib.discovery.problem.nested_test`; the jump's times the jump
    times) times the candidates is below 0.01, when V is right, by Monte Carlo over ``draws`` whitened residuals
    e ~ N(0, I): each candidate's drop is ``|Q_c' e|^2`` (Q_c: its whitened columns made orthogonal to the held
    model), the known-noise tail screens, the search's own test decides near the threshold. What a clean session
    of this design names at most, whatever the sensor (the design and V alone set it). Returns (rate, its standard
    error, candidate -> how often it would be named)."""
    prob, observable = final_problem(steps, ctx, [])
    held = [h for h in held if h in observable]
    cands = remaining(observable, held)

    def white(n):
        return prob.white_cols(n)[:, prob.keep[n]]

    q0 = np.linalg.qr(np.concatenate([prob.whiten(prob.rows(prob.base))] + [white(h) for h in held], axis=1))[0]

    def basis(c):
        r = c - q0 @ (q0.T @ c)
        u, sv, _ = np.linalg.svd(r, full_matrices=False)
        return u[:, sv > 1e-6 * max(sv.max(), 1e-300)]

    bases = {}
    for n in cands:
        times = prob.jump_grid if n == "bias_jump" else [None]
        bases[n] = []
        for tj in times:
            if tj is not None:
                prob.set_jump(tj)
            bases[n].append(basis(white(n)))
    mult = {n: len(bases[n]) for n in cands}  # the jump's Bonferroni over its times
    dof0 = q0.shape[0] - q0.shape[1]
    rng = np.random.default_rng(seed)
    named = dict.fromkeys(cands, 0)
    for start in range(0, draws, chunk):
        e = rng.standard_normal((q0.shape[0], min(chunk, draws - start)))
        rss0 = (e * e).sum(0) - ((q0.T @ e) ** 2).sum(0)
        best = {}
        for n in cands:
            drops = np.array([((b.T @ e) ** 2).sum(0) for b in bases[n]])
            qs = np.array([b.shape[1] for b in bases[n]])
            pv = stats.chi2.sf(drops, qs[:, None])
            j = pv.argmin(0)
            cols = np.arange(e.shape[1])
            best[n] = (np.minimum(1.0, pv[j, cols] * mult[n]), drops[j, cols], qs[j])
        screen = np.min([best[n][0] for n in cands], axis=0) * len(cands) < 0.03
        for i in np.flatnonzero(screen):
            ps = {}
            for n in cands:
                d, q = float(best[n][1][i]), int(best[n][2][i])
                dof = dof0 - q
                rss = float(rss0[i]) - d
                t = (d / q) / max(1.0, rss / dof)
                p = stats.f.sf(t, q, dof) if misfit(rss, dof, SCATTER_LEVEL)[0] else floored_sf(t, q, dof)
                ps[n] = min(1.0, p * mult[n])
            first = min(ps, key=ps.get)
            named[first] += int(ps[first] * len(cands) < 0.01)
    total = sum(v for n, v in named.items() if n != "bias_tempco")  # the real effect: never a false alarm
    return total / draws, float(np.sqrt(total)) / draws, named


def clean_pvalues(design: Design, n: int) -> list[tuple[dict, int]]:
    """The same over ``n`` clean sample-level trials of ``design`` (the seeds of :func:`clean_rates`)."""
    return [naming_pass(*design.session(np.random.default_rng(5000 + s))[:2]) for s in range(n)]


def family_events(rows: list[tuple[dict, int]], level: float = 0.01) -> int:
    """How many sessions' smallest candidate p-value times the candidates (:func:`naming_pass`) is below ``level``."""
    return sum(min(pv.values()) * n < level for pv, n in rows if pv)


def pvalue_lines(rows: list[tuple[dict, int]], label: str) -> list[str]:
    """Markdown rows: per candidate, how many p-values fall below 0.001, 0.01 and 0.05 (uniform under a
    calibrated test: n times that), and the Kolmogorov-Smirnov p-value against the uniform; then the
    sessions whose smallest p-value times the number of candidates is below 0.01 (Bonferroni's family)."""
    lines = []
    for name in sorted({k for r, _ in rows for k in r}):
        p = np.array([r[name] for r, _ in rows if name in r])
        ks = stats.kstest(p, "uniform").pvalue
        lines.append(f"| {label} | {name} | {len(p)} | {(p < 0.001).sum()} | {(p < 0.01).sum()} | {(p < 0.05).sum()} | "
                     f"{ks:.2g} |")
    lines.append(f"| {label} | (family: min p x candidates < 0.01) | {len(rows)} | | {family_events(rows)} | | |")
    return lines


def run_time(session: Path) -> tuple[float, float, int]:
    """(CLI seconds, search seconds, steps) of one discovery on ``session`` twice over (156 steps)."""
    s = load_session(session)
    idx = s.static_step_indices()
    st, ctx = step_means(s, idx), step_context(s, idx)
    span = float(np.ptp(st.t_s)) + 60.0
    both = StepMeans(names=st.names * 2, f_nominal_g=np.vstack([st.f_nominal_g] * 2),
                     mean_counts=np.vstack([st.mean_counts] * 2), sem_counts=np.vstack([st.sem_counts] * 2),
                     n_samples=np.concatenate([st.n_samples] * 2), temp_c=np.concatenate([st.temp_c] * 2),
                     t_s=np.concatenate([st.t_s, st.t_s + span]), lsb_per_g=st.lsb_per_g,
                     bias_stability=st.bias_stability, duration_s=np.concatenate([st.duration_s] * 2))
    ctx2 = StepContext(heating=np.concatenate([ctx.heating] * 2), base_to_sensor=np.concatenate([ctx.base_to_sensor] * 2),
                       temp_rate=np.concatenate([ctx.temp_rate] * 2),
                       angles_deg=np.concatenate([ctx.angles_deg] * 2))
    t0 = time.perf_counter()
    discover(both, ctx2)
    search = time.perf_counter() - t0
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "rig.cli", "discover", str(session), "--json"], cwd=REPO, check=True,
                   capture_output=True)
    return time.perf_counter() - t0, search, len(both)


def print_run_time(template: Path) -> None:
    cli_s, search_s, k = run_time(template)
    print(f"\nrun time: the search on a {k}-step session (tumble26 twice over) {search_s:.2f} s; "
          f"`rig discover --json` on the 78-step session end to end {cli_s:.2f} s (target < 10 s)")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--clean", type=int, default=100)
    ap.add_argument("--full", type=int, default=0, help="run N full clean dlpf sessions per recorded design")
    ap.add_argument("--first-seed", type=int, default=100, help="with --full: seeds FIRST .. FIRST + N - 1")
    ap.add_argument("--full-designs", default=",".join(FULL_DESIGNS),
                    help="with --full: comma-separated procedures to record (default: all four)")
    ap.add_argument("--geometry", choices=("on", "off"), default=None,
                    help="with --full: the simulated table's own errors (sim.geometry.enabled; discover then judges "
                         "against the rig's covariance); default: the rig file's")
    ap.add_argument("--characterised", type=int, default=None, metavar="SEED",
                    help="with --full: characterise the rig by reversal first (characterize_reversal.yaml with SEED, "
                         "then rig characterize-rig): the sessions are then judged with the characterisation")
    ap.add_argument("--family-draws", type=int, default=0,
                    help="with --full/--sessions: each design's own family rate by N draws of whitened noise")
    ap.add_argument("--rig-only", action="store_true",
                    help="only the full simulated-rig sessions (--full, --sessions): no templates, sample-level "
                         "runs, detection or run time")
    ap.add_argument("--sessions", action="append", default=[], help="glob of recorded clean session dirs")
    ap.add_argument("--no-mdm", action="store_true", help="skip the smallest-detected-magnitude search")
    ap.add_argument("--designs", default=None, help="comma-separated designs for the clean runs (default: all)")
    ap.add_argument("--effects", default=None, help="comma-separated effects for the detection runs (default: all)")
    ap.add_argument("--pvalues", action="store_true",
                    help="report each candidate's null p-values (calibration: uniform) on the clean sessions")
    ap.add_argument("--no-run-time", action="store_true", help="skip the run-time measurement")
    ap.add_argument("--templates", nargs=2, default=None, metavar=("TUMBLE26", "THERMAL"),
                    help="recorded dlpf sessions to use as templates instead of recording them")
    ap.add_argument("--matrix", action="store_true", help="only the grown hidden-effect matrix (issue 27), --seeds per cell")
    ap.add_argument("--rows", default=None, help="with --matrix: comma-separated row numbers of MATRIX (default: all)")
    ap.add_argument("--merge", action="store_true",
                    help="with --matrix: a proposal's extended session keeps the session's own noise on its steps "
                         "(a merge; default: the procedure run again, fresh noise, the same sensor)")
    args = ap.parse_args()
    global MERGE
    MERGE = args.merge
    if args.matrix:
        print_matrix(args.seeds, args.rows)
        return
    tmp = Path(tempfile.mkdtemp(prefix="bench-discover-"))
    if args.rig_only:
        print_full_rig(tmp, args)
        return
    if args.templates:
        templates = dict(zip(("tumble26", "thermal"), map(Path, args.templates)))
    else:
        print("recording the templates (tumble26, thermal) on the simulated rig, dlpf noise ...", flush=True)
        templates = {p: record(tmp, f"{p}.yaml", 1) for p in ("tumble26", "thermal")}
    designs = {"tumble26": Design.from_session(templates["tumble26"]),
               "tumble26_1khz": Design.from_session(templates["tumble26"], rate_factor=10),
               "thermal": Design.from_session(templates["thermal"]), "legs": legs_design(), "ramps": ramps_design()}

    if not args.no_run_time:
        print_run_time(templates["tumble26"])
    pv_rows: list[str] = []

    print(f"\nclean sessions, sample-level dlpf simulation ({args.clean} per design):")
    print("| design | steps | spurious names | gap_closed false | mean chi2/dof after |\n|---|---|---|---|---|")
    for name, des in designs.items():
        if args.designs and name not in args.designs.split(","):
            continue
        fa, gap, chi = clean_rates(des, args.clean)
        print(f"| {name} | {len(des.f)} | {fa}/{args.clean} | {gap}/{args.clean} | {chi:.3f} |", flush=True)
        if args.pvalues:
            pv_rows += pvalue_lines(clean_pvalues(des, args.clean), f"{name} (sample level)")

    print(f"\ndetection over {args.seeds} seeds at the stated magnitude (pattern x magnitude per axis):")
    print("| effect | design | magnitude | named | named alone (+ bias_tempco) | within 3 sigma | "
          "smallest named in >= 95 % |\n|---|---|---|---|---|---|---|")
    for cell, (field, pattern, mag) in CELLS.items():
        if args.effects and cell[0] not in args.effects.split(","):
            continue
        det, alone, within = detection(designs[cell[1]], cell, 1.0, args.seeds)
        mdm = "-" if args.no_mdm else smallest_detected(designs[cell[1]], cell, args.seeds)
        mdm = mdm if isinstance(mdm, str) else (f"{mdm:.3g}" if mdm is not None else f"> {FACTORS[-1] * mag:.3g}")
        print(f"| {cell[0]} | {cell[1]} | {mag:g} | {det}/{args.seeds} | {alone}/{args.seeds} | {within}/{det or 1} | "
              f"{mdm} |", flush=True)

    print_full_rig(tmp, args, pv_rows)


def print_full_rig(tmp: Path, args, pv_rows: list | None = None) -> None:
    """The clean full simulated-rig sessions (``--full``: recorded here; ``--sessions``: given): false alarms,
    verdict false alarms, the sessions whose smallest candidate p-value times the candidates is below 0.01
    (Bonferroni's family: what forward selection can name), the mean chi-square per dof after and the true
    residual's (:func:`true_residual_chi2`), then (``--pvalues``) each candidate's null p-values."""
    pv_rows = [] if pv_rows is None else pv_rows
    paths: dict = {}
    for pattern in args.sessions:
        for p in sorted(glob.glob(pattern)):
            inner = [q for q in Path(p).iterdir() if q.is_dir() and (q / "session.yaml").exists()]
            if inner:  # DIR/<procedure>-<seed>/<session>: grouped by the procedure
                paths.setdefault(Path(p).name.rsplit("-", 1)[0], []).append(inner[0])
    geometry = None if args.geometry is None else args.geometry == "on"
    if args.characterised is not None and args.full:
        print(f"rig characterised by reversal (seed {args.characterised}): {characterise_rig(tmp, args.characterised, geometry)}")
    for seed in range(args.first_seed, args.first_seed + args.full):
        for proc in args.full_designs.split(","):
            paths.setdefault(proc, []).append(record(tmp, f"{proc}.yaml", seed, geometry=geometry))
    if paths:
        print(f"\nclean full simulated-rig sessions (dlpf noise, table errors {args.geometry or 'as the rig file'}):")
        print("| design | sessions | spurious names | gap_closed false | family < 0.01 | named beyond the family | "
              "mean chi2/dof after | true residual chi2/n | spurious (seed) |\n|---|---|---|---|---|---|---|---|---|")
        for name, ps in paths.items():
            flags, gap, names, chi = full_rig(ps)
            n, fa = len(ps), sum(flags)
            pv = session_pvalues(ps)
            fam = family_events(pv)
            beyond = sum(f and not family_events([r]) for f, r in zip(flags, pv))  # named, no family event
            true = [c for c in map(true_residual_chi2, ps) if c is not None]
            true_s = f"{np.mean(true):.3f} +- {np.std(true) / np.sqrt(len(true)):.3f}" if true else "-"
            print(f"| {name} | {n} | {fa}/{n} | {gap}/{n} | {fam} | {beyond} | {chi:.3f} | {true_s} | {names} |",
                  flush=True)
            if args.pvalues:
                pv_rows += pvalue_lines(pv, f"{name} (full rig)")
    if pv_rows:
        print("\nnull p-values of each candidate at the pass where a spurious name would enter (the baseline + "
              "bias_tempco; the baseline alone where bias_tempco is not named) (calibrated: uniform; bias_jump's is "
              "Bonferroni over the jump times, conservative):")
        print("| sessions | candidate | n | p < 0.001 | p < 0.01 | p < 0.05 | KS p (uniform) |\n"
              "|---|---|---|---|---|---|---|")
        print("\n".join(pv_rows))
    if paths and getattr(args, "family_draws", 0):
        print(f"\nthe design's own family rate ({args.family_draws} draws of whitened noise, V right; the first "
              "session of each design):\n| design | held | candidates | spurious family rate (the search's test) | "
              "by candidate |\n|---|---|---|---|---|")
        for name, ps in paths.items():
            st, ctx = _steps_and_context(ps[0])
            held = held_model(candidate_pvalues(st, ctx, model=()))
            rate, se, by = family_rate(st, ctx, held, args.family_draws)
            print(f"| {name} | {held} | {len(by)} | {rate:.3%} +- {se:.3%} | {by} |", flush=True)


if __name__ == "__main__":
    main()
