"""Analysis: stability, state enumeration, transition graphs, sweeps, calibration.

The package itself imports nothing, so that light modules of it (``analysis.response``) load
without JAX; the stability API is :mod:`biplan.analysis.stability` (also ``biplan.classify``,
``biplan.reduced_hessian``, ``biplan.Stability``, ``biplan.Verdict``).
"""
