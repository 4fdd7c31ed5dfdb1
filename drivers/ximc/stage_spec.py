"""Facts about the rotation stages the rig uses, in one place.

The 8MR191-28 (Standa): a worm-gear rotation stage, 0.01 deg per full motor step (36000 full
steps per turn of the table), a 200-step motor whose controller limits it to a nominal
4800 full steps/s, i.e. 48 deg/s at the table. The controller (8SMC4/8SMC5) divides every
full step into up to 256 microsteps (``MICROSTEP_MODE_FRAC_256``).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class StageSpec:
    """Mechanics of one rotation stage with its motor.

    Attributes
    ----------
    name : str
        Standa's part number.
    deg_per_step : float
        Table rotation per full motor step, deg.
    steps_per_rev : int
        Full steps per revolution of the motor shaft (EngineSettings.StepsPerRev).
    nom_speed_steps_s : int
        Nominal (maximum) motor speed, full steps/s (EngineSettings.NomSpeed).
    """

    name: str
    deg_per_step: float
    steps_per_rev: int
    nom_speed_steps_s: int

    @property
    def max_speed_deg_s(self) -> float:
        """Fastest table rotation, deg/s (nominal speed times degrees per step)."""
        return self.nom_speed_steps_s * self.deg_per_step

    @property
    def steps_per_table_rev(self) -> int:
        """Full motor steps per 360 deg of the table."""
        return round(360.0 / self.deg_per_step)


#: Standa 8MR191-28 rotation stage (every axis of the rig)
MR191 = StageSpec(name="8MR191-28", deg_per_step=0.01, steps_per_rev=200, nom_speed_steps_s=4800)

#: the rig's speed limit, deg/s (48 deg/s: 4800 full steps/s at 0.01 deg/step)
MAX_SPEED_DEG_S: float = MR191.max_speed_deg_s
