"""Maps over a grid of designs: the grid, chunked sweeps with their store, design, stability
and first-instability maps, and the cost estimates checked before a sweep runs."""
