"""Calibration of fold laws from measured specimens: the specimen data and its files, the fits,
the calibration itself, synthetic specimens and validation (these know the laws, not the
model); and the fit of the fully bistable laws to the paper's Fig. 4 by a search over state
enumerations (:mod:`biplan.calibration.fig4_search`, MODEL §17.1.4)."""
