"""The JAX reference implementations the compiled core replaced, kept as the tests' oracles.

Each is the whole-tube autodiff version of a compiled loop: the globalised Newton
(:mod:`.core`, :mod:`.strategies`, :mod:`.newton`), the batched observation and stability test
(:mod:`.observe`), the nudged elastic band (:mod:`.neb`), the deflated Newton
(:mod:`.deflation`) and the generalized-α time loop (:mod:`.dynamics`). The package runs none
of them; the tests compare the compiled results with them.
"""
