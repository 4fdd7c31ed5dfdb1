"""Plots people can read (issue #13 item 16): ``rig discover --plot`` and ``rig history --plot``.

The figures are inspected as matplotlib objects (tick labels, titles, axis labels, texts, the
legend's place on the drawn canvas), not only as files on disk.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from rig.analysis import plots
from rig.analysis.discover import discover_session, write_plot
from rig.cli import main
from rig.errors import RigInputError
from rig.lab import open_history, plot_history, sensor_history
from rig.lab.units import shown_unit

from conftest import PROCEDURES, REPO

POSES = ["+Z up", "+X up", "-Z up", "-X up", "+Y up", "-Y up"]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A six-position session of the simulated rig (thermometer on), and its history database."""
    out = tmp_path_factory.mktemp("plots")
    db = out / "history.sqlite"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RIG_HISTORY", str(db))
        assert main(["run", str(PROCEDURES / "six_position.yaml"), "--seed", "4", "--time-scale", "0",
                     "--out", str(out / "s"), "--quiet"]) == 0
    (session,) = (out / "s").iterdir()
    return session, db


@pytest.fixture(scope="module")
def no_thermometer(recorded, tmp_path_factory):
    """The same recording with a manifest that says the sensor has no thermometer."""
    session, _ = recorded
    copy = tmp_path_factory.mktemp("nothermo") / session.name
    shutil.copytree(session, copy)
    doc = yaml.safe_load((copy / "session.yaml").read_text())
    doc["rig"]["sensor"]["has_temperature"] = False
    doc.pop("seal", None)  # changed by hand: no longer the sealed recording (docs/session-format.md, "Seal")
    (copy / "session.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    return copy


def _drawn(fig):
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _data_axes(fig):
    return [a for a in fig.axes if a.get_visible() and a.lines]


def _texts(ax) -> list[str]:
    return [t.get_text() for t in ax.texts]


# ---------------------------------------------------------------------------------------------- --plot PATH

def test_a_directory_becomes_a_file_inside_it_and_the_path_is_absolute(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "plots").mkdir()
    p = plots.resolve_plot_path("plots", "s1-discover.png")
    assert p == (tmp_path / "plots" / "s1-discover.png").resolve() and p.is_absolute()
    created = plots.resolve_plot_path("new/", "x.png")  # a trailing slash names a directory: created
    assert created == (tmp_path / "new" / "x.png").resolve() and (tmp_path / "new").is_dir()
    assert plots.resolve_plot_path("r.svg", "x.png") == (tmp_path / "r.svg").resolve()
    with pytest.raises(RigInputError, match="--plot: expected a .png"):
        plots.resolve_plot_path("notes.txt", "x.png")
    with pytest.raises(RigInputError, match="no such directory"):
        plots.resolve_plot_path("missing/r.png", "x.png")
    assert plots.safe_name("MPU-9150@0x68#0x68/sim-seed-3") == "MPU-9150_0x68_0x68_sim-seed-3"


def test_discover_plot_into_a_directory_writes_inside_and_prints_the_real_path(recorded, tmp_path, capsys,
                                                                               monkeypatch):
    session, _ = recorded
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out").mkdir()
    assert main(["discover", str(session), "--plot", "out"]) == 0
    printed = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("plot: ")]
    path = Path(printed[0].removeprefix("plot: "))
    assert path.is_absolute() and path.parent == (tmp_path / "out").resolve()
    assert path.name == f"{session.name}-discover.png" and path.read_bytes()[:4] == b"\x89PNG"
    assert b"matplotlib.org" not in path.read_bytes()  # no web address stamped into the file
    assert main(["discover", str(session), "--json", "--plot", str(tmp_path / "out")]) == 0
    assert json.loads(capsys.readouterr().out)["plot"] == str(path)


def test_history_plot_into_a_directory_writes_inside_and_prints_the_real_path(recorded, tmp_path, capsys):
    _, db = recorded
    assert main(["history", "sim-seed-4", "--history", str(db), "--plot", str(tmp_path)]) == 0
    printed = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("plot: ")]
    path = Path(printed[0].removeprefix("plot: "))
    assert path.parent == tmp_path.resolve() and path.name.startswith("history-MPU-9150") and path.stat().st_size > 10_000


def test_a_bad_plot_path_is_one_line_exit_2(recorded, tmp_path, capsys):
    session, db = recorded
    assert main(["discover", str(session), "--plot", str(tmp_path / "r.txt")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("rig discover: ") and err.count("\n") == 1 and "--plot" in err
    assert main(["history", "sim-seed-4", "--history", str(db), "--plot", str(tmp_path / "no" / "h.png")]) == 2
    assert "no such directory" in capsys.readouterr().err


# ---------------------------------------------------------------------------------------------- what the figures show

def test_discover_figure_names_the_session_labels_steps_with_poses_and_uses_one_unit(recorded):
    session, _ = recorded
    s, d = discover_session(session)
    fig = write_plot(d, session_id=s.id)  # no path: the Figure itself
    _drawn(fig)
    assert s.id in fig._suptitle.get_text()
    step_axes = [a for a in fig.axes if a.get_xlabel().startswith("step")]
    assert len(step_axes) == 2
    for ax in step_axes:
        assert [t.get_text() for t in ax.get_xticklabels()] == POSES
    for ax in _data_axes(fig):  # every residual axis and every title with a residual figure says µg
        assert ax.get_ylabel() == "residual, µg"
        assert "rms" not in ax.get_title() or "µg rms" in ax.get_title()
    text = " ".join([fig._suptitle.get_text()] + [a.get_title() + a.get_ylabel() for a in fig.axes])
    assert not re.search(r"\b(mg|ug)\b", text)
    # the numbers in the titles are the residuals plotted (µg), not another unit
    before = np.array([st.residual_before_g for st in d.steps]) * 1e6
    assert f"{np.sqrt(np.mean(before ** 2)):.1f} µg rms" in step_axes[0].get_title()


def test_the_temperature_panels_show_temperatures_when_the_sensor_has_a_thermometer(recorded):
    session, _ = recorded
    s, d = discover_session(session)
    fig = write_plot(d, session_id=s.id)
    temp_axes = [a for a in fig.axes if "temperature" in a.get_xlabel()]
    assert len(temp_axes) == 2 and all(a.lines for a in temp_axes)
    assert not any(plots.NO_TEMPERATURE in _texts(a) for a in fig.axes)


def test_a_session_without_temperature_data_says_so_instead_of_empty_panels(no_thermometer):
    s, d = discover_session(no_thermometer)
    assert all(st.temp_c is None for st in d.steps)
    fig = write_plot(d, session_id=s.id)
    empty = [a for a in fig.axes if plots.NO_TEMPERATURE in _texts(a)]
    assert len(empty) == 2
    for ax in empty:
        assert not ax.lines and not ax.collections  # no data drawn, only the text
    # and the generic builder does the same for a single series (the report's layout)
    one = plots.residuals_figure("t", POSES, [None] * 6, [("calibration", np.zeros((6, 3)))])
    assert [plots.NO_TEMPERATURE in _texts(a) for a in one.axes] == [False, True]


@pytest.mark.parametrize("series", [1, 2])
def test_the_legend_is_outside_every_axes_so_it_covers_no_data(recorded, series):
    session, _ = recorded
    s, d = discover_session(session)
    if series == 2:
        fig = write_plot(d, session_id=s.id)
    else:
        r = np.array([st.residual_after_g for st in d.steps]) * 1e6
        fig = plots.residuals_figure("one", [st.name for st in d.steps], [st.temp_c for st in d.steps],
                                     [("calibration", r)])
    renderer = _drawn(fig)
    assert all(a.get_legend() is None for a in fig.axes)  # no legend inside a panel
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["x", "y", "z"]
    box = legend.get_window_extent(renderer)
    for ax in fig.axes:
        assert not box.overlaps(ax.get_window_extent(renderer)), ax.get_title()
    # and inside the figure, not cut off
    fig_box = fig.bbox
    assert fig_box.x0 <= box.x0 and box.x1 <= fig_box.x1 and fig_box.y0 <= box.y0 and box.y1 <= fig_box.y1


def test_many_steps_keep_pose_names_on_the_step_axis_readable(recorded):
    names = [f"pose {i}" for i in range(100)]
    fig = plots.residuals_figure("many", names, None, [("r", np.zeros((100, 3)))])
    labels = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert 20 <= len(labels) <= plots.MAX_STEP_LABELS and set(labels) <= set(names) and labels[0] == "pose 0"


def test_history_figure_names_the_sensor_units_on_axes_and_the_sessions(recorded):
    session, db = recorded
    with open_history(db, create=False) as h:
        key = next(r["sensor_key"] for r in h.query("SELECT sensor_key FROM sensors"))
        records = sensor_history(h, key)
    fig = plot_history(key, records)
    _drawn(fig)
    assert key in fig._suptitle.get_text()
    panels = {a.get_title(): a for a in fig.axes if a.get_visible() and a.get_title()}
    # the unit on the axis (the one rig run prints: angles in mrad), the name in the title: one unit each
    units = {n: shown_unit(u) for n, (_, _, u) in records[0].parameters.items()}
    assert set(panels) == set(units) and units["accel.alpha_yz"] == "mrad"
    for name, ax in panels.items():
        assert ax.get_ylabel() == units[name]
        assert [t.get_text() for t in ax.get_xticklabels()] == [f"#{i + 1}" for i in range(len(records))]
    (legend,) = [a for a in fig.axes if a.get_visible() and not a.get_title()]  # the table under the panels
    assert "six_position" in " ".join(t.get_text() for t in legend.texts)
    assert session.name in fig._supxlabel.get_text()


def test_matplotlib_is_imported_only_when_a_plot_is_drawn():
    code = ("import sys, rig.analysis.plots, rig.analysis.discover, rig.lab.drift, rig.cli.main; "
            "print('matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
