"""The sensor frame: its axes, in the order of every vector and matrix in ``calib``."""

#: sensor-frame axes (x, y, z): the order of every (3,) vector and every row/column of a (3, 3) matrix
SENSOR_AXES: tuple[str, str, str] = ("x", "y", "z")
