"""The history compares like with like (issue 33 items 1, 4 and 8).

A sensor's history of 50 calibrations, built from one real `rig run` of the simulated rig (its calibration
row, through rig.lab.history's own API, at 50 times; every 7th a thermal calibration stating its bias at
t0 = 40 C with its own bias polynomial): the table, the JSON, the drift verdict and the figure show the
biases at one reference temperature, the figure stays readable (every text inside, tick labels apart), the
angles are in mrad as `rig run` prints them, and records of the simulated rig stay out of the default view.
"""

from __future__ import annotations

import copy
import json
import math
import sqlite3
from datetime import datetime, timedelta, timezone

import pytest
from matplotlib.text import Text

from rig.cli import main
from rig.lab import drift, format_history, history_document, open_history, plot_history, sensor_history
from rig.lab.history import MIGRATIONS, calibration_row, is_simulated, store_row
from rig.session.manifest import SessionManifest

from conftest import PROCEDURES

TEMPCO = -4.9  # counts/C, bias_x of the thermal calibrations
THERMAL_T0_C = 40.0


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref")
    assert main(["run", str(PROCEDURES / "six_position.yaml"), "--seed", "3", "--time-scale", "0", "--out", str(out),
                 "--quiet"]) == 0
    (s,) = [p for p in out.iterdir() if p.is_dir()]
    return s


@pytest.fixture(scope="module")
def base(session):
    return calibration_row(session, session / "calibration.yaml")


def _row(base: dict, k: int, *, thermal: bool = False, temp_c: float | None = None, key: str | None = None,
         simulated: int | None = None) -> dict:
    """Calibration ``k`` of the sensor: the same numbers as the run (no ageing), a day later each."""
    row = copy.deepcopy(base)
    c = row["calibration"]
    c["calibrated_at"] = (datetime(2026, 1, 1, 9, tzinfo=timezone.utc) + timedelta(days=k)).isoformat()
    c["session_id"] = f"{c['session_id']}-{k}"
    if key is not None:
        row["sensor"]["key"] = key
    if simulated is not None:
        c["simulated"] = simulated
    params = row["parameters"]
    if temp_c is not None:
        c["temp_mean_c"] = temp_c
    if thermal:  # the bias at t0 = 40 C, by the sensor's own tempco
        t = base["calibration"]["temp_mean_c"]
        params = [(n, v + TEMPCO * (THERMAL_T0_C - t), s * 0.5, u) if n == "accel.bias_x" else (n, v, s, u)
                  for n, v, s, u in params]
        params += [("accel.t0_c", THERMAL_T0_C, None, "C"), ("accel.tempco1_x", TEMPCO, 0.03, "counts/C^1"),
                   ("accel.tempco1_y", 0.0, 0.03, "counts/C^1"), ("accel.tempco1_z", 0.0, 0.03, "counts/C^1")]
        c["temp_mean_c"] = THERMAL_T0_C + 0.3
    row["parameters"] = params
    return row


@pytest.fixture(scope="module")
def fifty(base, tmp_path_factory):
    db = tmp_path_factory.mktemp("fifty") / "h.sqlite"
    for k in range(50):
        store_row(_row(base, k, thermal=k % 7 == 3), history=db)
    with open_history(db) as h:
        records = sensor_history(h, base["sensor"]["key"])
    assert len(records) == 50
    return base["sensor"]["key"], records


def _panel(fig, name: str):
    (ax,) = [a for a in fig.axes if a.get_title() == name]
    return ax


def _points(ax) -> list[float]:
    return [y for line in ax.get_lines() if line.get_marker() in ("o", "D") for y in line.get_ydata()]


def test_thermal_calibrations_plot_and_compare_at_the_sensors_usual_temperature(fifty, base):
    key, records = fifty
    stated = [r.parameters["accel.bias_x"][0] for r in records]
    assert max(stated) - min(stated) > 50  # as stated: a 'jump' of 60 counts at every thermal calibration
    values = _points(_panel(plot_history(key, records), "accel.bias_x"))
    sigma = base["parameters"][0][2]
    assert len(values) == 50 and max(values) - min(values) < 3 * sigma  # at one temperature: flat
    doc = history_document(key, records)
    ref_c = doc["reference_temperature"]["temp_c"]
    assert ref_c == pytest.approx(base["calibration"]["temp_mean_c"])
    thermal = doc["calibrations"][3]["parameters"]["accel.bias_x"]
    assert thermal["at_reference"]["temp_c"] == ref_c and not thermal["at_reference"]["own_temperature"]
    assert thermal["at_reference"]["value"] == pytest.approx(base["parameters"][0][1], abs=1e-9)
    # the sigma carried over 12 C gains 12 x sigma(tempco) in quadrature
    assert thermal["at_reference"]["sigma"] == pytest.approx(math.hypot(sigma * 0.5, 0.03 * (THERMAL_T0_C - ref_c)))
    assert thermal["change"]["at_temp_c"] == ref_c and abs(thermal["change"]["z"]) < 1e-6
    assert doc["flagged"] == [] and not any(c and c["flagged"] for c in drift(records)["accel.bias_x"])
    table = format_history(key, records)
    assert f"accelerometer biases at {ref_c:.1f} C" in table and "#4 from its t0 40.0 C" in table
    assert "no drift beyond 3 combined sigma" in table


def test_the_figure_of_50_calibrations_keeps_every_text_inside_and_apart(fifty):
    key, records = fifty
    fig = plot_history(key, records)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    texts = [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()
             and not (t.get_clip_on() and t.get_clip_box() is not None)]  # a clipped text stays in its panel
    for t in texts:
        e = t.get_window_extent(renderer)
        assert e.x0 >= box.x0 - 1 and e.y0 >= box.y0 - 1 and e.x1 <= box.x1 + 1 and e.y1 <= box.y1 + 1, t.get_text()
    for ax in fig.axes:
        labels = [t for t in ax.get_xticklabels() if t.get_visible() and t.get_text()]
        assert len(labels) <= 12
        extents = sorted((t.get_window_extent(renderer) for t in labels), key=lambda e: e.x0)
        assert all(a.x1 < b.x0 for a, b in zip(extents, extents[1:]))  # no label over another
    legend = " ".join(t.get_text() for t in texts)
    assert all(f"#{k} " in legend for k in range(1, 51))  # the legend table names every calibration
    assert "2026-02-19 09:00" in legend and "six_position" in legend


def test_a_bias_no_model_can_move_is_marked_with_its_own_temperature(base, tmp_path):
    db = tmp_path / "h.sqlite"
    t = base["calibration"]["temp_mean_c"]
    for k in range(4):
        store_row(_row(base, k, temp_c=t + 3.0 if k == 2 else None), history=db)
    with open_history(db) as h:
        records = sensor_history(h, base["sensor"]["key"])
    table = format_history(base["sensor"]["key"], records)
    assert f"@{t + 3.0:.1f}C" in table and "stated at their own temperature" in table and "#3" in table
    doc = history_document(base["sensor"]["key"], records)
    assert doc["calibrations"][2]["parameters"]["accel.bias_x"]["at_reference"]["own_temperature"]
    assert doc["calibrations"][2]["parameters"]["accel.bias_x"]["change"]["across_temp_c"] == \
        [pytest.approx(t), pytest.approx(t + 3.0)]
    ax = _panel(plot_history(base["sensor"]["key"], records), "accel.bias_x")
    assert [line for line in ax.get_lines() if line.get_marker() == "D" and list(line.get_xdata()) == [2]]


def test_history_shows_angles_in_mrad_like_rig_run(fifty, capsys):
    key, records = fifty
    table = format_history(key, records)
    alpha = records[0].parameters["accel.alpha_yz"]
    assert alpha[2] == "rad"  # stored as the calibration file states it
    (line,) = [x for x in table.splitlines() if x.startswith("accel.alpha_yz")]
    assert line.startswith("accel.alpha_yz (mrad)") and f"{alpha[0] * 1e3:.6g}+-{alpha[1] * 1e3:.2g}" in line
    ax = _panel(plot_history(key, records), "accel.alpha_yz")
    assert ax.get_ylabel() == "mrad" and _points(ax)[0] == pytest.approx(alpha[0] * 1e3)


def test_simulated_records_stay_out_of_the_default_view(session, base, tmp_path, capsys):
    db = tmp_path / "h.sqlite"
    assert main(["history", "--record", str(session), "--history", str(db)]) == 0  # a simulated run
    with open_history(db) as h:
        assert [r["simulated"] for r in h.query("SELECT simulated FROM calibrations")] == [1]
    _, manifest = SessionManifest.load(session)  # the same session as a hardware rig would record it
    manifest["rig"]["turntable"]["kind"] = "standa-8smc"
    hardware = calibration_row(session, session / "calibration.yaml", manifest=manifest, sensor_id="HW-1")
    assert hardware["calibration"]["simulated"] == 0
    store_row(hardware, history=db)
    store_row(_row(base, 9, key="MPU-9150:HW-1"), history=db)  # a simulated run under the hardware unit's id
    capsys.readouterr()
    assert main(["history", "--history", str(db)]) == 0
    out = capsys.readouterr().out
    assert "MPU-9150:HW-1" in out and "sim-seed-3" not in out and "1 sensor(s) calibrated only on the simulated" in out
    assert main(["history", "--history", str(db), "--all"]) == 0
    out = capsys.readouterr().out
    assert "sim-seed-3" in out and "(1 simulated)" in out
    assert main(["history", "HW-1", "--history", str(db), "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)["calibrations"]) == 1  # its hardware calibration only
    assert main(["history", "HW-1", "--history", str(db), "--json", "--all"]) == 0
    assert sorted(c["simulated"] for c in json.loads(capsys.readouterr().out)["calibrations"]) == [False, True]
    assert main(["history", "sim-seed-3", "--history", str(db)]) == 0  # a simulated sensor, named: shown
    assert "1 calibration(s)" in capsys.readouterr().out


@pytest.mark.parametrize("kind, simulated", [("sim:8smc5-emulator", True), ("sim:8smc5-controller-in-memory", True),
                                             ("replay:8smc5-emulator", True), ("standa-8smc", False), (None, False)])
def test_which_rigs_are_simulated(kind, simulated):
    manifest = {"rig": {"kind": "import" if kind is None else None, "turntable": {"kind": kind} if kind else None}}
    assert is_simulated(manifest) is simulated  # an imported recording (rig.kind import) is not


def test_records_stored_before_the_migration_are_marked_by_their_rig(base, tmp_path):
    db = tmp_path / "old.sqlite"
    with sqlite3.connect(db) as conn:  # a version-2 database, as rig wrote it before
        conn.execute("CREATE TABLE schema_version (version INTEGER NOT NULL)")
        for version, steps in MIGRATIONS[:2]:
            for sql in steps:
                conn.execute(sql)
            conn.execute("INSERT INTO schema_version VALUES (?)", (version,))
        conn.execute("INSERT INTO sensors VALUES ('MPU-9150@0x68#0x68/sim-seed-3', 'MPU-9150', 104, NULL, NULL, 'x')")
        conn.execute("INSERT INTO sensors VALUES ('MPU-9150:HW-1', 'MPU-9150', 104, NULL, 'HW-1', 'x')")
        for key, rig in (("MPU-9150@0x68#0x68/sim-seed-3", '{"axes": {}, "kind": "sim:8smc5-emulator"}'),
                         ("MPU-9150:HW-1", '{"axes": {}, "kind": "replay:8smc5-emulator"}'),
                         ("MPU-9150:HW-1", '{"axes": {}, "kind": "standa-8smc"}')):
            conn.execute("INSERT INTO calibrations (sensor_key, recorded_at, rig) VALUES (?, 'x', ?)", (key, rig))
    with open_history(db) as h:
        assert [r[0] for r in h.query("SELECT simulated FROM calibrations ORDER BY id")] == [1, 1, 0]


def test_the_table_of_50_calibrations_keeps_to_120_characters_and_wide_shows_every_column(fifty):
    """The walkthrough: 314 characters a line at 12 calibrations, 550 at 14: unreadable on a terminal."""
    key, records = fifty
    table = format_history(key, records).splitlines()
    start = next(i for i, x in enumerate(table) if x.startswith("parameter (unit)"))
    rows = table[start:start + 1 + len([x for x in table[start + 1:] if x.startswith("accel.")])]
    assert all(len(x) <= 120 for x in rows), max(map(len, rows))
    head = rows[0].split()
    assert head[2] == "#1" and head[3] == "..." and head[-1] == "#50"  # the baseline and the newest
    (note,) = [x for x in table if x.startswith("(#2..#")]
    assert f"rig history {key} --wide shows every calibration" in note
    wide = format_history(key, records, None).splitlines()
    assert all(f"#{k}" in wide[start].split() for k in range(1, 51)) and not any(x.startswith("(#2..#") for x in wide)


def test_an_off_temperature_calibration_is_carried_by_the_sensors_own_tempcos_not_called_drift(base, tmp_path):
    """The walkthrough: a six-position calibration at 35 C (no temperature model) beside calibrations at 27.6 C and a
    thermal one was flagged 'drift beyond 3 combined sigma: accel.bias_x, ...' though the sensor's own tempco (from
    its thermal calibration) explained the shift to within a count."""
    db = tmp_path / "h.sqlite"
    t = base["calibration"]["temp_mean_c"]
    warm = copy.deepcopy(base)  # the same sensor calibrated at t + 7.3 C: its bias moved by its tempco
    warm["parameters"] = [(n, v + TEMPCO * 7.3, s, u) if n == "accel.bias_x" else (n, v, s, u)
                          for n, v, s, u in warm["parameters"]]
    rows = [_row(base, 0), _row(base, 1, thermal=True), _row(base, 2), _row(warm, 3, temp_c=t + 7.3)]
    for row in rows:
        store_row(row, history=db)
    with open_history(db) as h:
        records = sensor_history(h, base["sensor"]["key"])
    d = drift(records)
    assert not any(c and c["flagged"] for c in d["accel.bias_x"]), d["accel.bias_x"]
    doc = history_document(base["sensor"]["key"], records)
    at = doc["calibrations"][3]["parameters"]["accel.bias_x"]["at_reference"]
    assert at["carried_by_calibration"] == 2 and not at["own_temperature"]
    assert at["value"] == pytest.approx(base["parameters"][0][1], abs=1e-6)
    sigma = base["parameters"][0][2]
    assert at["sigma"] == pytest.approx(math.hypot(sigma, 0.03 * 7.3))  # the tempco's sigma over the move
    table = format_history(base["sensor"]["key"], records)
    assert "#4 from " in table and "by the tempcos of #2" in table and "no drift beyond 3 combined sigma" in table
    # without a thermal calibration in the history nothing can move it: marked with its own temperature, as before
    db2 = tmp_path / "h2.sqlite"
    for row in (rows[0], rows[2], rows[3]):
        store_row(row, history=db2)
    with open_history(db2) as h:
        records = sensor_history(h, base["sensor"]["key"])
    assert f"@{t + 7.3:.1f}C" in format_history(base["sensor"]["key"], records)
