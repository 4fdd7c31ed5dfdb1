"""Standa 8SMC4/8SMC5 controllers with 8MR191 rotation stages.

``protocol`` (sans-I/O codec), ``transaction`` (sans-I/O link policy: retries, resynchronisation,
reopening), ``link`` (the thin pyserial shell that carries it out), ``stage_spec`` (stage facts:
``MR191``, ``MAX_SPEED_DEG_S``), ``errors`` (``TurntableError``), ``stage`` (``Stage``: the
libximc-named command set and degrees). Simulator: ``drivers.ximc.sim``.
"""
