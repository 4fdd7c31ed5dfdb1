"""Among aliases `rig discover` names the physically plausible explanation (issue 27: never name what the data do
not support). The walkthrough's case: a six-position session at one temperature with a hidden scale nonlinearity was
told `Missing from the model: scale_tempco ... Add it`, with a scale tempco of about 300 %/C, because the
temperature moved by a fraction of a degree and the two effects are aliases on six faces."""

from __future__ import annotations

import contextlib
import io

import yaml

from calib.discovery.effects import PLAUSIBLE_MAX, plausible
from rig.analysis.discover import discover_session
from rig.cli import main

from conftest import PROCEDURES, RIGS


def test_a_scale_nonlinearity_on_six_faces_is_not_named_a_scale_tempco_of_hundreds_of_percent(tmp_path):
    doc = yaml.safe_load((RIGS / "sim.yaml").read_text())
    doc["sim"]["effects"] = {"scale_nonlinearity": 2e-3}
    rig = tmp_path / "rig.yaml"
    rig.write_text(yaml.safe_dump(doc))
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["run", str(PROCEDURES / "six_position.yaml"), "--rig", str(rig), "--seed", "3", "--time-scale", "0",
                     "--out", str(tmp_path / "s"), "--quiet"]) == 0
    (session,) = (tmp_path / "s").iterdir()
    _, d = discover_session(session)
    named = {e.name: e for e in d.effects}
    assert "scale_tempco" not in named, {n: e.estimate for n, e in named.items()}
    assert all(plausible(n, e.estimate) for n, e in named.items())
    if d.aliases:  # still reported as aliases, the plausible one first
        assert all(group[0] != "scale_tempco" for group in d.aliases)


def test_plausibility_is_a_bound_on_every_parameter():
    assert plausible("scale_tempco", [2e-4, -1e-4, None if False else 0.0])
    assert not plausible("scale_tempco", [2e-4, 3.0, 0.0])
    assert plausible("pose_error", [10.0])  # no bound
    assert plausible("bias_jump", [float("nan"), 0.1, 0.0]) and set(PLAUSIBLE_MAX) < set(
        __import__("calib.discovery.effects", fromlist=["LIBRARY"]).LIBRARY)
