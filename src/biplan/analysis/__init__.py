"""Analysis of a model: stability and modes, and the workflows built on the solvers.

- :mod:`~biplan.analysis.stability`, :mod:`~biplan.analysis.modes`: one equilibrium.
- :mod:`~biplan.analysis.response`: a load ramp under force, displacement or dynamics.
- :mod:`~biplan.analysis.states`: the stable-state landscape (search, catalogue, labels,
  transitions, barriers).
- :mod:`~biplan.analysis.maps`: design and stability maps over a grid of designs, and the
  runners that spread chunked work over processes or a Dask cluster.
- :mod:`~biplan.analysis.sensitivity`: exact derivatives of results with respect to design
  parameters, and inverse design.

The packages import nothing themselves, so that light modules load without JAX.
"""
