"""The simulated turntable's own errors: a table of three stacked worm-gear stages as imperfect as hardware.

The geometry chain (per-stage angular errors, lost motion, wobble, inter-axis non-orthogonalities, the
sensor's mounting, local gravity) is :mod:`calib.numerics.turntable`, the one implementation the world model
evaluates and the uncertainty budget propagates. This module draws a hidden table from the datasheet
classes (:class:`GeometryClass`). The motor angle and its last direction come from the emulated controllers
(``drivers.ximc.sim``), which speak the protocol unchanged: every error lives in the world model. Class values
and their sources: ``docs/simulated-rig.md`` ("The turntable's own errors").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.numerics.budget import TableClass
from calib.numerics.gravity import G0_M_S2
from calib.numerics.turntable import StageErrors, TableGeometry, small_rotation

__all__ = ["G0_M_S2", "GeometryClass", "StageErrors", "TableGeometry", "small_rotation"]


@dataclass(frozen=True)
class GeometryClass(TableClass):
    """The datasheet-class magnitudes the hidden geometry is drawn from (``sim.geometry``): the classes the
    uncertainty budget states (:class:`calib.numerics.budget.TableClass`, the one place of their values;
    half-widths of rectangular distributions, except the non-negative lost motion and wobble, drawn in [0, a]).
    The values and their sources are in ``docs/simulated-rig.md`` ("The turntable's own errors")."""

    def draw(self, rng: np.random.Generator, gravity_m_s2: float = G0_M_S2) -> TableGeometry:
        """A hidden geometry drawn from these classes (every phase uniform in [0, 360))."""
        def signed(a, n=None):
            return rng.uniform(-a, a, n)

        stages = tuple(StageErrors(
            zero_offset_deg=float(signed(self.zero_offset_deg)),
            periodic_deg=float(signed(self.periodic_deg)), periodic_phase_deg=float(rng.uniform(0, 360)),
            period_deg=self.period_deg,
            accumulated_deg=float(signed(self.accumulated_deg)), accumulated_phase_deg=float(rng.uniform(0, 360)),
            lost_motion_deg=float(rng.uniform(0, self.lost_motion_deg)),
            wobble_deg=float(rng.uniform(0, self.wobble_deg)), wobble_phase_deg=float(rng.uniform(0, 360)))
            for _ in range(3))
        return TableGeometry(stages=stages,
                             non_orthogonality_deg=tuple(float(x) for x in signed(self.non_orthogonality_deg, 3)),
                             mounting_deg=tuple(float(x) for x in signed(self.mounting_deg, 3)),
                             gravity_m_s2=float(gravity_m_s2))
