"""Jobs from a procedure (or a recorded session) to a calibration file: run and replay share one lifecycle."""
