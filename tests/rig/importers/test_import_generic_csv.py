"""``rig import --from csv`` writes a typed manifest (import section, no turntable) that loads and solves."""

from __future__ import annotations

import numpy as np
import pytest

from rig.errors import RigInputError
from rig.importers.recordings import import_recording
from rig.session import load_session, step_means

POSES = {"+X up": [1, 0, 0], "-X up": [-1, 0, 0], "+Y up": [0, 1, 0], "-Y up": [0, -1, 0], "+Z up": [0, 0, 1],
         "-Z up": [0, 0, -1]}


def _csv(tmp_path, crlf=False):
    rng = np.random.default_rng(1)
    lines = ["# units: counts", "# lsb_per_g: 16384", "t_s,ax,ay,az,temp_c,label"]
    t = 0.0
    for name, f in POSES.items():
        for _ in range(50):
            a = np.round(np.array(f) * 16384 + 100 + rng.normal(0, 5, 3)).astype(int)
            lines.append(f"{t:.3f},{a[0]},{a[1]},{a[2]},25.0,{name}")
            t += 0.01
    p = tmp_path / "rec.csv"
    p.write_bytes(("\r\n" if crlf else "\n").join(lines).encode() + b"\n")
    return p


def test_a_labelled_csv_imports_as_a_session_with_an_import_section(tmp_path):
    d = import_recording("csv", _csv(tmp_path), tmp_path / "out", "rec")
    s = load_session(d)
    assert s.info.rig.kind == "import" and s.info.rig.turntable is None
    assert s.info.import_.source == "csv" and s.info.import_.lsb_per_g == 16384.0 and s.info.import_.units == "counts"
    assert s.info.to_dict()["import"]["steps_from"] == "labels"
    assert [st.name for st in s.info.steps] == list(POSES) and all(st.status == "complete" for st in s.info.steps)
    np.testing.assert_allclose(step_means(s).f_nominal_g, np.array(list(POSES.values()), float), atol=1e-12)


def test_a_bad_cell_names_file_line_and_column(tmp_path):
    p = _csv(tmp_path)
    lines = p.read_text().splitlines()
    lines[9] = lines[9].replace(",25.0,", ",warm,")
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(RigInputError, match=r"rec.csv:10: temp_c: expected a number, got 'warm'"):
        import_recording("csv", p, tmp_path / "out", "rec")
