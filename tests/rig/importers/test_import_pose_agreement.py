"""An import applies the session reader's pose rule (a static step reads gravity within 20 deg of its label),
so a recording the reader would refuse is refused at import, naming the source file, and never written as a
session that then refuses to load; a recording within the rule imports and loads."""

from __future__ import annotations

import math

import pytest

from rig.cli import main
from rig.session import load_session

HEAD = "# units: g\nt_s,ax,ay,az,label\n"


def _csv(tilt_deg: float) -> str:
    """Six labelled poses; the +X up step reads gravity ``tilt_deg`` away from +X (towards +Y)."""
    c, s = math.cos(math.radians(tilt_deg)), math.sin(math.radians(tilt_deg))
    poses = {"+X up": (c, s, 0), "-X up": (-1, 0, 0), "+Y up": (0, 1, 0), "-Y up": (0, -1, 0), "+Z up": (0, 0, 1),
             "-Z up": (0, 0, -1)}
    rows, t = [], 0.0
    for label, (x, y, z) in poses.items():
        for k in range(20):
            rows.append(f"{t:.2f},{x + 1e-3 * (k % 3):.6f},{y:.6f},{z:.6f},{label}")
            t += 0.01
    return HEAD + "\n".join(rows) + "\n"


@pytest.mark.parametrize("tilt", [25.0, 35.0])
def test_a_step_beyond_the_readers_pose_rule_is_refused_at_import_naming_the_source(tmp_path, capsys, tilt):
    src = tmp_path / "r.csv"
    src.write_text(_csv(tilt))
    assert main(["import", "--from", "csv", str(src), "-o", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"rig import: {src}: +X up: ") and "mislabelled" in err[0], err
    assert not (tmp_path / "s").exists() or not any((tmp_path / "s").iterdir())


def test_a_step_within_the_rule_imports_and_loads(tmp_path, capsys):
    src = tmp_path / "r.csv"
    src.write_text(_csv(10.0))
    assert main(["import", "--from", "csv", str(src), "-o", str(tmp_path / "s"), "--id", "ok"]) == 0
    assert len(load_session(tmp_path / "s" / "ok").step_means()) == 6
