"""``rig sim``: start emulated controllers on pseudo-terminals and show the simulated sensor."""

from __future__ import annotations

import math

from drivers.sensors.chips import SENSOR_MODELS
from rig.cli.common import UsageError
from rig.simulation.tools import serve_sim

#: pseudo-terminals one `rig sim` may open
MAX_CONTROLLERS = 32


def add_parser(sub) -> None:
    sm = sub.add_parser("sim", help="start emulated controllers; show the simulated sensor")
    sm.add_argument("--count", type=int, default=3)
    sm.add_argument("--time-scale", type=float, default=1.0)
    sm.add_argument("--seed", type=int, default=0)
    sm.add_argument("--sensor", choices=SENSOR_MODELS, default=SENSOR_MODELS[0])
    sm.add_argument("--once", action="store_true", help="print and exit instead of serving until Ctrl-C")


def run(args) -> int:
    if not 1 <= args.count <= MAX_CONTROLLERS:
        raise UsageError(f"--count: expected 1 to {MAX_CONTROLLERS} controllers, got {args.count}")
    if not (math.isfinite(args.time_scale) and 0 < args.time_scale <= 1000):
        raise UsageError(f"--time-scale: expected a speed-up above 0 and up to 1000, got {args.time_scale:g}")
    if not 0 <= args.seed < 2**32:
        raise UsageError(f"--seed: expected an integer from 0 to {2**32 - 1}, got {args.seed}")
    return serve_sim(count=args.count, time_scale=args.time_scale, seed=args.seed, sensor_model=args.sensor,
                     once=args.once)
