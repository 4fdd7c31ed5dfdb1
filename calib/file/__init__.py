"""The calibration file (``rig-calibration/1``, docs/calibration-file.md): its sections
(``section``: one base class, the per-sensor sections declare fields), the file itself
(``calibration``: read, write; ``apply``: the one way to apply it to a recording), the one guarded
YAML loader of every format of the project (``yamlsafe``), the one field dialect of every typed
format and its located one-line errors (``fields``: field types, ``Strict``, ``describe``) and every
calibrated quantity as a flat named scalar (``parameters``).
"""
