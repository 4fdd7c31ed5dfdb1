"""The new library effects hidden in simulated tumble26 sessions, and the verdict (`gap_closed`).

``bias_jump`` runs the shipped tumble26; ``bias_tempco_cubic`` needs 4 or more temperatures, so it
runs tumble26 with its cooling legs moved to 31 and 24 C. ``thermal_gradient`` is tested at the step
level (tests/calib/test_discovery_verdict.py): tumble26 takes its steps after the chamber settles,
so the step rates are ~1e-3 C/s and the within-step slope of the temperature samples is too noisy
(~6e-4 C/s) to determine it. An effect outside the library (a bias in sin a1) is injected by editing
a clean session's samples. The sessions are recorded by ``rig run`` in this process (``rig.cli.main``).
"""

from __future__ import annotations

import contextlib
import csv
import io
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from rig.analysis.discover import discover_session, format_report
from rig.cli import main

from conftest import PROCEDURES, RIGS, unseal

SEED = 5
CUBIC = 2e-6  # g/C^3
JUMP = (2e-3, 2000.0)  # g, s
T0_5T = 26.27  # mean step temperature of tumble26 with cooling legs at 31 and 24 C


def _run(tmp: Path, name: str, procedure: Path, effects: dict | None, errors: dict | None = None) -> Path:
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"]["time_scale"] = 0
    doc["sim"]["noise"] = "dlpf"
    if errors:
        doc["sim"]["errors"] = errors
    if effects:
        doc["sim"]["effects"] = effects
    rig = tmp / f"{name}.yaml"
    rig.write_text(yaml.safe_dump(doc))
    out = tmp / name
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["run", str(procedure), "--rig", str(rig), "--out", str(out), "--seed", str(SEED), "--quiet"])
    assert code == 0, err.getvalue()
    return next(out.iterdir())


def _five_temperatures(tmp: Path) -> Path:
    doc = yaml.safe_load((PROCEDURES / "tumble26.yaml").read_text())
    temps = [s["temperature"] for s in doc["steps"] if "temperature" in s]
    temps[3]["target_c"], temps[4]["target_c"] = 31.0, 24.0
    path = tmp / "tumble26_5t.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("discover_new")
    t26 = PROCEDURES / "tumble26.yaml"
    jobs = {"bias_jump": (t26, {"bias_jump": JUMP[0], "bias_jump_t_s": JUMP[1]}),
            "bias_tempco_cubic": (_five_temperatures(tmp), {"bias_tempco_cubic": CUBIC}),
            "clean": (t26, None)}
    # the simulator's cubic is centred on t_ref_c; centred on the session's mean temperature (the search's
    # t0) it is a pure cubic plus linear terms only, so nothing but the cubic and bias_tempco is expected
    errors = {"bias_tempco_cubic": {"t_ref_c": T0_5T}}
    # one after the other, in this process (the test workers run modules side by side)
    out = {n: _run(tmp, n, p, e, errors.get(n)) for n, (p, e) in jobs.items()}
    out["outside"] = _add_sin_a1_bias(out["clean"], tmp / "outside", 2e-3)
    return out


def _add_sin_a1_bias(src: Path, dst: Path, amp_g: float) -> Path:
    """A copy of a session with a bias amp * sin(a1) on every axis (no library effect describes it)."""
    shutil.copytree(src, dst)
    lsb = float(yaml.safe_load((src / "sim_truth.yaml").read_text()).get("lsb_per_g", 8192.0))
    with open(src / "samples.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        db = int(round(amp_g * lsb * np.sin(np.radians(float(r["a1_deg"])))))
        for c in ("ax", "ay", "az"):
            r[c] = str(int(r[c]) + db)
    with open(dst / "samples.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return unseal(dst)  # edited data: no longer the sealed recording (docs/session-format.md, "Seal")


@pytest.mark.parametrize("effect, truth", [("bias_jump", [JUMP[0]] * 3), ("bias_tempco_cubic", [CUBIC] * 3)])
def test_a_new_hidden_effect_is_named_within_3_sigma_and_the_gap_closes(sessions, effect, truth):
    s, d = discover_session(sessions[effect])
    named = [e.name for e in d.effects]
    assert effect in named and set(named) <= {effect, "bias_tempco"}, named
    e = next(e for e in d.effects if e.name == effect)
    assert np.all(np.abs(np.array(e.estimate) - truth) < 3 * np.array(e.sigma)), (e.estimate, e.sigma)
    j = d.to_json()
    assert j["gap_closed"] is True and "unexplained" not in j
    assert j["chi2_per_dof_after"] < j["chi2_per_dof_before"]
    if effect == "bias_jump":
        assert abs(j["effects"][named.index(effect)]["t_jump_s"] - JUMP[1]) < 30.0
    assert "the model now explains the data to the noise level" in format_report(s, d)


def test_a_clean_session_closes_the_gap_with_bias_tempco_only(sessions):
    _, d = discover_session(sessions["clean"])
    assert [e.name for e in d.effects] == ["bias_tempco"]
    j = d.to_json()
    assert j["format"] == "rig-discover/6" and j["gap_closed"] is True


def test_an_effect_outside_the_library_leaves_the_gap_open_and_says_where(sessions):
    s, d = discover_session(sessions["outside"])
    j = d.to_json()
    assert j["gap_closed"] is False, [e.name for e in d.effects]
    u = j["unexplained"]
    assert "by_outer_axis_deg" in u and any(x["significant"] for x in u["structure"])
    text = format_report(s, d)
    assert "something remains" in text and "look for" in text
