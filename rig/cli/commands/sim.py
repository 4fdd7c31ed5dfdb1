"""``rig sim``: start emulated controllers on pseudo-terminals and show the simulated sensor."""

from __future__ import annotations

from rig.simulation.tools import serve_sim


def add_parser(sub) -> None:
    sm = sub.add_parser("sim", help="start emulated controllers; show the simulated sensor")
    sm.add_argument("--count", type=int, default=3)
    sm.add_argument("--time-scale", type=float, default=1.0)
    sm.add_argument("--seed", type=int, default=0)
    sm.add_argument("--sensor", choices=["MPU-9150", "ADXL345"], default="MPU-9150")
    sm.add_argument("--once", action="store_true", help="print and exit instead of serving until Ctrl-C")


def run(args) -> int:
    return serve_sim(count=args.count, time_scale=args.time_scale, seed=args.seed, sensor_model=args.sensor,
                     once=args.once)
