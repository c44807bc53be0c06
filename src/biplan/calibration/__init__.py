"""Calibration of fold laws from measured specimens: the specimen data and its files, the fits,
the calibration itself, synthetic specimens and validation. Knows the laws, not the model."""
