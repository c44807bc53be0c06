"""Local terms of the BiPlan Lagrangian, evaluated per element and assembled (main Eq.
mft_energy_assembly; MODEL §4–7, §11).

The strain energy and the constraints are sums of local terms, as in a finite-element code:

* a **module** element n sees its own coordinates x_n = (u_n, φ1_n, φ2_n): the helical field
  energy, the two guides g (SI Eq. 11) and the two helical contact gaps (w0, wa) (SI Eq. bound);
* a **connector** element c sees x_c = (x_lower, x_upper, γ_c) (7 numbers; the clamp's
  coordinates are absent for the base fold): the energies of its circular fields and its
  contact gaps (MODEL C1).

Each kind of element is one small pure function of its local coordinates; its gradient,
Hessian and constraint Jacobian come from local autodiff, and ``vmap`` lifts it over the chain
(the element is the unit of compilation; the number of elements is an array dimension). The
local blocks are added into the global gradient, Hessian and Jacobian by one scatter per
kind of block, at the indices of static tables (:func:`topology`): O(N) work beside the dense
result. Only the load point z_p sees the whole chain (module frames compose along it); its
derivatives split into per-connector blocks and the Hessian of a cumulative sum
(:func:`chain_terms`). The dense autodiff of the whole Lagrangian is kept as the independent
test oracle (:mod:`biplan.model.oracle`).

A new kind of fold or connector is one local function of its element's coordinates (as
:func:`module_lagrangian`, :func:`connector_lagrangian`) plus its rows of the index tables.
"""

from biplan.model.elements.chainterm import ChainTerms, chain_terms, load_point_height
from biplan.model.elements.local import (
    ConnectorData,
    LocalTerms,
    connector_gaps,
    connector_lagrangian,
    connector_points,
    local_terms,
    module_constraints,
    module_lagrangian,
)
from biplan.model.elements.topology import (
    CONNECTOR_DOFS,
    Topology,
    place_matrix,
    place_vector,
    topology,
)

__all__ = [
    "CONNECTOR_DOFS",
    "ChainTerms",
    "ConnectorData",
    "LocalTerms",
    "Topology",
    "chain_terms",
    "connector_gaps",
    "connector_lagrangian",
    "connector_points",
    "load_point_height",
    "local_terms",
    "module_constraints",
    "module_lagrangian",
    "place_matrix",
    "place_vector",
    "topology",
]
