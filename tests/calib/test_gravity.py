"""Local gravity with its standard uncertainty (issue 29 item 4): measured, normal gravity from latitude and
height (GRS80 Somigliana with the second-order height term), or standard gravity with the spread of gravity
over the Earth; the rig file states it (``gravity:``), one line for every bad statement."""

from __future__ import annotations

import math

import pytest

from calib.numerics import gravity
from rig.config.rigfile import parse_rig_file
from rig.errors import RigInputError


def test_normal_gravity_is_grs80_at_the_equator_the_poles_and_a_published_benchmark():
    assert gravity.normal_gravity_m_s2(0.0) == pytest.approx(9.7803267715, abs=1e-10)
    assert gravity.normal_gravity_m_s2(90.0) == pytest.approx(9.8321863685, abs=1e-9)  # GRS80 gamma_b
    # in-dubio-pro-geo.de's worked example: 51.03361 deg, 149 m ellipsoidal height -> 9.811161 m/s^2
    # (a measured absolute value there: 9.811193, 3.2 mGal away, well inside the anomaly's uncertainty)
    g = gravity.from_site(51.03361, 149.0)
    assert g.g_m_s2 == pytest.approx(9.811161, abs=3e-6)
    assert abs(9.811193 - g.g_m_s2) < math.sqrt(3) * g.u_m_s2
    assert gravity.normal_gravity_m_s2(45.0, 1000.0) - gravity.normal_gravity_m_s2(45.0) == pytest.approx(
        -3.086e-3, rel=2e-3)  # the free-air gradient, 0.3086 mGal/m


def test_unknown_site_is_standard_gravity_with_the_earths_spread_as_its_uncertainty():
    g = gravity.standard_gravity()
    assert g.g_m_s2 == 9.80665
    for lat, h in ((0.0, 3000.0), (90.0, 0.0), (45.0, 0.0)):  # every inhabited site inside the half-width
        assert abs(gravity.normal_gravity_m_s2(lat, h) - g.g_m_s2) <= math.sqrt(3) * g.u_m_s2
    assert g.relative_u == pytest.approx(2.1e-3, rel=0.05)


BASE = """format: rig-file/1
kind: sim
turntable:
  axes: {a1: {}, a2: {}, a3: {}}
sensor: {model: MPU-9150}
"""


def test_the_rig_file_states_gravity_measured_or_from_its_site_and_defaults_to_standard_gravity():
    assert parse_rig_file(BASE).gravity == gravity.standard_gravity()
    site = parse_rig_file(BASE + "gravity: {latitude_deg: 51.03361, height_m: 149}\n").gravity
    assert site == gravity.from_site(51.03361, 149.0)
    g = parse_rig_file(BASE + "gravity: {g_m_s2: 9.811193, u_m_s2: 1.0e-5}\n").gravity
    assert (g.g_m_s2, g.u_m_s2, g.source) == (9.811193, 1.0e-5, "measured")


@pytest.mark.parametrize("text, where, says", [
    ("gravity: {g_m_s2: 9.81, latitude_deg: 3}", "gravity.g_m_s2", "not both"),
    ("gravity: {height_m: 3}", "gravity:", "expected g_m_s2 (measured) or latitude_deg"),
    ("gravity: {g_m_s2: 98.1}", "gravity.g_m_s2", "[9.7, 9.9]"),
    ("gravity: {latitude_deg: 52, u_m_s2: -1}", "gravity.u_m_s2", "expected"),
    ("gravity: 9.81", "gravity:", "expected a mapping"),
])
def test_a_bad_gravity_statement_is_one_line_with_its_line_and_key(text, where, says):
    with pytest.raises(RigInputError) as exc:
        parse_rig_file(BASE + text + "\n", "r.yaml")
    line = str(exc.value)
    assert line.startswith("r.yaml:6: ") and where in line and says in line and "\n" not in line
