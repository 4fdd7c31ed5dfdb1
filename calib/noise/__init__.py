"""A sensor's noise, as the Allan deviation states it (docs/noise.md).

- :mod:`calib.noise.terms`: the noise terms (white noise N, bias instability B, random walk K, rate
  ramp R), the Allan-variance model they add up to, and how long a recording each term needs.
- :mod:`calib.noise.allan`: the overlapping Allan deviation of one axis with its confidence intervals
  (allantools, imported when a deviation is computed).
- :mod:`calib.noise.fit`: the terms fitted to a deviation, with their uncertainties and the fit quality.
- :mod:`calib.noise.checks`: what a characterisation refuses: gaps, a moving sensor, a record too short.
- :mod:`calib.noise.synthetic`: noise with known terms (tests and benchmarks; no runtime module imports it).

Imports nothing from ``rig`` or ``drivers``.
"""
