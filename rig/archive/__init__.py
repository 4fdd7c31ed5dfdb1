"""Session archives (docs/archive.md): many session directories as one partitioned Parquet dataset
(:mod:`rig.archive.store`), re-solved in chunks on a process pool (:mod:`rig.archive.resolve`).

The session directory stays the recording contract (``rig-session/1``): an archive holds every file of each
session, its samples as columns, and gives any session back as a directory whose seal verifies.
"""
