"""Calibration (``hcv calibrate``): the value of a code's own option that delivers a
target restitution, with its options checked (`_options`) and the run-to-run noise of the
calibrated quantity (`_noise`). The entry point is `calibrate.calibrate`.
"""

__all__: list[str] = []
