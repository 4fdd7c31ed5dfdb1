"""The sensor tests itself when a session starts: the result is in the manifest, a failing chip
stops the run before anything is recorded."""

from __future__ import annotations

import pytest
import yaml

from rig.cli import main
from rig.workflow import lifecycle

from conftest import REPO

SIX = str(REPO / "procedures" / "six_position.yaml")


@pytest.fixture(autouse=True)
def self_test_on(monkeypatch):
    monkeypatch.setattr(lifecycle, "SELF_TEST_AT_START", True)


def test_a_good_chip_passes_and_the_result_is_recorded(tmp_path):
    # the self-test runs when the session starts: 1 s dwells instead of 10 s test the same (issue 26)
    six = tmp_path / "six_position.yaml"
    six.write_text((REPO / "procedures" / "six_position.yaml").read_text().replace("dwell: {seconds: 10}",
                                                                                   "dwell: {seconds: 1}"))
    assert main(["run", str(six), "--seed", "4", "--time-scale", "0", "--out", str(tmp_path / "s"), "--quiet"]) == 0
    (session,) = (tmp_path / "s").iterdir()
    result = yaml.safe_load((session / "session.yaml").read_text())["rig"]["sensor"]["self_test"]
    assert result["passed"] is True and len(result["axes"]) == 6


def test_a_failing_chip_stops_the_run_with_one_line_and_records_nothing(tmp_path, capsys):
    rig = yaml.safe_load((REPO / "rigs" / "sim.yaml").read_text())
    rig["faults"] = {"sensor": {"failed_self_test": True}}
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(rig))
    code = main(["run", SIX, "--rig", str(tmp_path / "bad.yaml"), "--time-scale", "0", "--out",
                 str(tmp_path / "s"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and "self-test FAILED" in err[0]
    assert not (tmp_path / "s").exists() or not any((tmp_path / "s").iterdir())
