"""The emulated 8SMC5 controller.

``controller`` (sans-I/O ``Controller``: bytes in, bytes out, a handler per command),
``axis`` (``StageModel`` and the motion state), ``motion`` (trapezoidal profiles),
``faults`` (``XimcFaults``), ``pty`` (``PtyServer``: the pseudo-terminal thread),
``emulator`` (``ControllerEmulator``: a controller served on a pty).
"""
