"""``python -m benchmarks.adversarial [options]``: the adversarial campaign (see the package's docstring)."""

from .campaign import main

raise SystemExit(main())
