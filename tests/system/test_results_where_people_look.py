"""Results where people look (issue 33 item 4): what `rig run` and `rig solve` print states every estimated
parameter with its sigma, tempcos included; effects that the fit tested and did not need are named as such;
an exactly determined fit says so instead of a chi2/dof of 0.00."""

from __future__ import annotations

import json
import re

import pytest

from rig.cli import main

from conftest import PROCEDURES


@pytest.fixture(scope="module")
def ramp_run(tmp_path_factory):
    """``rig run procedures/thermal_ramp.yaml`` in virtual time: (its printout, its session directory)."""
    root = tmp_path_factory.mktemp("ramp")
    with pytest.MonkeyPatch.context() as mp, pytest.MonkeyPatch.context():
        mp.setenv("RIG_HISTORY", str(root / "h.sqlite"))
        import contextlib
        import io

        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            assert main(["run", str(PROCEDURES / "thermal_ramp.yaml"), "--seed", "2", "--time-scale", "0",
                         "--out", str(root / "s"), "--quiet"]) == 0
    return out.getvalue(), next((root / "s").iterdir())


def test_the_bias_tempcos_are_printed_with_their_sigmas_and_the_bias_says_at_which_temperature(ramp_run):
    out, _ = ramp_run
    (line,) = [x for x in out.splitlines() if x.strip().startswith("bias tempco (counts/C):")]
    assert re.fullmatch(r"\s*bias tempco \(counts/C\): x [+-][\d.]+ \+- [\d.]+  y [+-][\d.]+ \+- [\d.]+  "
                        r"z [+-][\d.]+ \+- [\d.]+", line), line
    biases = [x for x in out.splitlines() if re.match(r"\s*[xyz]: bias", x)]
    assert len(biases) == 3 and all("counts (at t0 " in b for b in biases)


def test_effects_the_fit_did_not_need_are_named_as_tested_and_not_needed(ramp_run):
    out, _ = ramp_run
    assert "effects: thermal_gradient, scale_tempco" not in out  # what was printed: as if they had been found
    (line,) = [x for x in out.splitlines() if "tested, not needed" in x]
    assert "thermal_gradient" in line and "scale_tempco" in line and "3 sigma" in line


def test_an_exactly_determined_fit_says_so(simulated_lab, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("RIG_HISTORY", str(tmp_path / "h.sqlite"))
    assert main(["solve", str(simulated_lab["six"]), "--method", "flip", "-o", str(tmp_path / "flip.yaml")]) == 0
    out = capsys.readouterr().out
    assert "chi2/dof 0.00" not in out and "exactly determined" in out
    assert main(["solve", str(simulated_lab["six"]), "-o", str(tmp_path / "pinv.yaml")]) == 0
    out = capsys.readouterr().out
    assert "exactly determined" not in out and re.search(r"chi2/dof \d+\.\d\d", out)


def test_discover_says_first_that_nothing_is_missing_beyond_what_the_calibration_models(ramp_run, capsys):
    """Issue 33 item 3: on a thermal session `rig discover` opened with the baseline's chi2/dof and 'N of M
    step-axis means disagree' and never said that the session's own calibration (thermal: 1) already models
    the bias tempco it found."""
    _, session = ramp_run
    assert main(["discover", str(session)]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("Nothing is missing beyond bias_tempco, which this session's calibration already "
                            "models") and first.endswith("Nothing to act on.")


def test_discover_names_what_is_missing_first_with_the_command_that_adds_it(ramp_run, tmp_path, capsys):
    import shutil

    _, session = ramp_run
    d = tmp_path / session.name
    shutil.copytree(session, d)
    (d / "calibration.yaml").unlink()  # no calibration with a thermal model beside it: the tempco is missing
    assert main(["discover", str(d)]) == 0
    first, second = capsys.readouterr().out.splitlines()[:2]
    assert first.startswith("Missing from the model: bias_tempco")
    assert second == f"Add it: rig discover {d} -o CALIB.yaml writes the calibration with it (docs/discrepancy.md)."


def test_discover_on_a_clean_session_says_there_is_nothing_to_act_on(simulated_lab, capsys):
    assert main(["discover", str(simulated_lab["six"])]) == 0
    assert capsys.readouterr().out.splitlines()[0] == ("Nothing is missing: the model explains this session to its "
                                                       "noise level. Nothing to act on.")


def test_discover_keeps_its_statistics_behind_details_on_the_console(simulated_lab, capsys):
    """Issue 33 item 3: the console shows the verdict, what was named and the gap; the statistics (tested and not
    needed, detectable magnitudes, the per-step table) only with --details; --json always has them."""
    six = str(simulated_lab["six"])
    assert main(["discover", six]) == 0
    short = capsys.readouterr().out
    assert main(["discover", six, "--details"]) == 0
    full = capsys.readouterr().out
    assert short.splitlines()[0] == full.splitlines()[0]
    for statistic in ("per step (residual, ug; before -> after):", "smallest detectable magnitude per candidate",
                      "where the model and the data disagree:"):
        assert statistic in full and statistic not in short
    assert "gap: " in short and "verdict: " in short
    assert short.splitlines()[-1] == (f"the statistics (where the data disagree, effects tested and not needed, "
                                      f"detectable magnitudes, the per-step table): rig discover {six} --details "
                                      "(or --json)")
    assert main(["discover", six, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["observability"] and doc["steps"]
