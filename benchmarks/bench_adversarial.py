"""Adversarial campaign: generated bad inputs against every file-reading command and option, plus process faults.

    python benchmarks/bench_adversarial.py            # full campaign
    python benchmarks/bench_adversarial.py --quick    # a sample of every attack class, a few process trials
    python benchmarks/bench_adversarial.py --jobs 2 --seed 2026 --filter samples

The attack classes, the runner and the report are the package ``benchmarks/adversarial/`` (one module per
class: procedures, rig files, sessions, calibration files, imports, options, output paths, names, signals,
concurrency); its docstring says what is attacked and how each answer is classified. ``python -m
benchmarks.adversarial`` runs the same campaign.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from adversarial.campaign import main

if __name__ == "__main__":
    raise SystemExit(main())
