"""Standa 8SMC4/8SMC5 controllers with 8MR191 rotation stages.

``protocol`` (sans-I/O codec), ``stage_spec`` (stage facts: ``MR191``, ``MAX_SPEED_DEG_S``),
``errors`` (``TurntableError``), ``link`` (serial transactions with retries), ``stage``
(``Stage``: the libximc-named command set and degrees). Simulator: ``drivers.ximc.sim``.
"""
