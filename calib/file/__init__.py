"""The calibration file (``rig-calibration/1``, docs/calibration-file.md): its sections
(``section``: one base class, the per-sensor sections declare fields), the file itself
(``calibration``: read, write, apply), the guarded YAML loader (``yamlsafe``) and every calibrated
quantity as a flat named scalar (``parameters``).
"""
