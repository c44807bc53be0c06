"""The dynamic snap of the semi-bistable design past its instability: which circular fold
opens when.

Run:  .venv/bin/python benchmarks/snap_sequence.py

Force ramp 0.8 N/s to 2.24 N (t = 2.8 s), held to 3.2 s; backward Euler, h = 10 ms (halved
automatically through the snap), Rayleigh damping for ζ = 5 % of the first mode at 1 N.
Prints, for every circular fold, the time at which more than half of its length is open, the
peak kinetic energy, and the final state. A fold-by-fold (serrated) transformation shows as
opening times spread over the ramp; a cascade within milliseconds means that, under force
control, once the first fold goes all go.
"""

from __future__ import annotations

import numpy as np

import biplan
from biplan.analysis.modes import natural_modes, rayleigh_for_damping_ratio
from biplan.solvers import BackwardEuler, ControlKind


def main() -> None:
    model = biplan.Model(biplan.designs.semi_bistable())
    ref = biplan.relaxed_reference(model)
    s = biplan.solve_equilibrium(model, None, ref, biplan.Load.of_force(1.0))
    alpha = rayleigh_for_damping_ratio(natural_modes(model, s), 0.05)
    history = biplan.LoadHistory(ControlKind.FORCE, (0.0, 2.8, 3.2), (0.0, 2.24, 2.24))
    tr = biplan.integrate(
        model, BackwardEuler(time_step=0.01, rayleigh=alpha), ref, t_end=3.2, load=history
    )
    print(tr.message)
    n = model.layout.n_modules
    names = biplan.solvers.results.fold_names(model)[n:]
    open_frac = tr.phase_fraction[:, n:, 2]
    for c, name in enumerate(names):
        idx = np.flatnonzero(open_frac[:, c] > 0.5)
        when = f"t = {tr.time[idx[0]]:.6f} s, F = {tr.force[idx[0]]:.4f} N" if idx.size else "never"
        print(f"{name:14s} opens at {when}")
    k = int(np.argmax(tr.kinetic_energy))
    print(f"peak kinetic energy {tr.kinetic_energy[k]:.3f} N·mm at t = {tr.time[k]:.6f} s")
    l0 = model.tube.initial_length
    print(
        f"final: u_z/l0 = {tr.u_z[-1] / l0:.4f}, u_r/l0 = {tr.u_r[-1] / l0:.4f}, "
        f"theta = {tr.theta[-1]:.4f} rad, stable = {bool(tr.stable[-1])}"
    )


if __name__ == "__main__":
    main()
