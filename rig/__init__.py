"""Calibration rig controller: procedures, runner, sessions, replay, simulated rig, CLI."""

__version__ = "0.1.0"
