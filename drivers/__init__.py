"""Hardware drivers of the rig and their wire-level simulators.

- ``drivers.clock``: the ``Clock`` every driver and simulator waits and timestamps with.
- ``drivers.ximc``: the Standa 8SMC4/8SMC5 turntable controllers (protocol, ``Stage``, stage facts);
  ``drivers.ximc.sim``: the emulated controller.
- ``drivers.sensors``: the I2C sensors (register maps, drivers, chip registry);
  ``drivers.sensors.sim``: the simulated bus and chips.

Runtime drivers never import a ``sim`` package; ``drivers`` imports nothing from ``rig`` or ``calib``.
"""
