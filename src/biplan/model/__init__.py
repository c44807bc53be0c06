"""The model: the only package that knows both the laws and the geometry.

- :mod:`~biplan.model.tube`: a tube as a design (geometry, layout and fold laws).
- :mod:`~biplan.model.elements`: the chain's local element terms (energy, guides, gaps).
- :mod:`~biplan.model.params`: the traced parameters and the :class:`Load` of the kernels.
- :mod:`~biplan.model.potential`: energy, guides, contact gaps and load point as functions of q.
- :mod:`~biplan.model.lagrangian`: the Lagrangian, the KKT residual and Jacobian.
- :mod:`~biplan.model.assembly`: the compiled kernels of a layout and :class:`Model`.
- :mod:`~biplan.model.inertia`: the mass matrix of the shell.
- :mod:`~biplan.model.oracle`: an independent dense implementation, for the tests.

The package imports nothing itself, so that :mod:`~biplan.model.tube` loads without JAX.
"""
