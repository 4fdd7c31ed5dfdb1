"""Local gravity and its standard uncertainty (docs/uncertainty.md, "Gravity").

The calibration file's unit is g0 = 9.80665 m/s^2 (standard gravity): a rig at a site where gravity is g
sees a specific force of g / g0 at rest, so a stated g that is off by dg biases every scale factor by
dg / g. Three ways to state it, each with its standard uncertainty u (GUM):

- **measured** (a gravimeter, a national gravity survey or map): ``g`` with the ``u`` the source states
  (default :data:`MEASURED_U_M_S2`);
- **normal gravity** from latitude and ellipsoidal height: the GRS80 Somigliana formula with the
  second-order height term (Moritz, *Geodetic Reference System 1980*, J. Geodesy 74 (2000) 128-133);
  the actual gravity differs from it by the site's gravity anomaly, taken as a rectangular distribution
  of half-width :data:`ANOMALY_HALF_WIDTH_M_S2` (100 mGal; free-air anomalies over land rarely exceed it
  outside high mountains);
- **nothing stated**: standard gravity, with the rectangular spread of gravity over the inhabited Earth
  (g0 +- 0.036 m/s^2, 9.771 .. 9.843: the equator at 3 km height, 9.771, to the poles, 9.832) about it, half-width
  :data:`UNKNOWN_HALF_WIDTH_M_S2`.

Pure numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: standard gravity, m/s^2 (CGPM 1901; the calibration file's g)
G0_M_S2 = 9.80665
#: GRS80: normal gravity at the equator (m/s^2), Somigliana's k, first eccentricity squared, semi-major
#: axis (m), flattening and m = omega^2 a^2 b / GM
GRS80_GAMMA_E = 9.7803267715
GRS80_K = 0.001931851353
GRS80_E2 = 0.00669438002290
GRS80_A_M = 6378137.0
GRS80_F = 1.0 / 298.257222101
GRS80_M = 0.00344978600308
#: half-width of the gravity anomaly about normal gravity (rectangular), m/s^2 (100 mGal)
ANOMALY_HALF_WIDTH_M_S2 = 1.0e-3
#: half-width of gravity over the inhabited Earth about g0 (rectangular), m/s^2
UNKNOWN_HALF_WIDTH_M_S2 = 0.036
#: standard uncertainty of a measured value whose source states none, m/s^2 (5 mGal: a gravity map)
MEASURED_U_M_S2 = 5.0e-5


@dataclass(frozen=True)
class Gravity:
    """Local gravity as the calibration assumes it.

    Attributes
    ----------
    g_m_s2 : the value, m/s^2.
    u_m_s2 : its standard uncertainty, m/s^2.
    source : "measured", "normal gravity (lat, h)" or "standard gravity (site unknown)".
    """

    g_m_s2: float
    u_m_s2: float
    source: str

    @property
    def relative_u(self) -> float:
        """u / g: the relative standard uncertainty every scale factor inherits."""
        return self.u_m_s2 / self.g_m_s2

    def to_dict(self) -> dict:
        return {"g_m_s2": self.g_m_s2, "u_m_s2": self.u_m_s2, "source": self.source}


def normal_gravity_m_s2(latitude_deg: float, height_m: float = 0.0) -> float:
    """GRS80 normal gravity at geodetic latitude ``latitude_deg`` and ellipsoidal height ``height_m``, m/s^2:
    ``gamma_e (1 + k sin^2 phi) / sqrt(1 - e^2 sin^2 phi) (1 - 2 (1 + f + m - 2 f sin^2 phi) h / a + 3 h^2 / a^2)``."""
    s2 = math.sin(math.radians(latitude_deg)) ** 2
    gamma0 = GRS80_GAMMA_E * (1.0 + GRS80_K * s2) / math.sqrt(1.0 - GRS80_E2 * s2)
    h = float(height_m)
    return gamma0 * (1.0 - 2.0 * (1.0 + GRS80_F + GRS80_M - 2.0 * GRS80_F * s2) * h / GRS80_A_M
                     + 3.0 * (h / GRS80_A_M) ** 2)


def standard_gravity() -> Gravity:
    """g0 with the spread of gravity over the inhabited Earth as its (rectangular) uncertainty."""
    return Gravity(G0_M_S2, UNKNOWN_HALF_WIDTH_M_S2 / math.sqrt(3.0), "standard gravity (site unknown)")


def from_site(latitude_deg: float, height_m: float = 0.0, u_m_s2: float | None = None) -> Gravity:
    """Normal gravity at the site, with the anomaly's rectangular uncertainty unless ``u_m_s2`` is given."""
    u = ANOMALY_HALF_WIDTH_M_S2 / math.sqrt(3.0) if u_m_s2 is None else float(u_m_s2)
    return Gravity(normal_gravity_m_s2(latitude_deg, height_m), u,
                   f"normal gravity (GRS80, latitude {latitude_deg:g} deg, height {height_m:g} m)")


def measured(g_m_s2: float, u_m_s2: float | None = None) -> Gravity:
    """A measured value with its stated standard uncertainty (default :data:`MEASURED_U_M_S2`)."""
    return Gravity(float(g_m_s2), MEASURED_U_M_S2 if u_m_s2 is None else float(u_m_s2), "measured")
