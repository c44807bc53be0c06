"""One :class:`System` between the model and every iteration: the KKT system of a tube at a
load, evaluated by compiled element kernels (Numba) with the tube's layout as data.

The kernels (:mod:`.elements`, :mod:`.fields`, :mod:`.chainterm`, :mod:`.endpoint`,
:mod:`.assemble`) compile once per install (:func:`biplan._compile.numba_cache.kernel`:
Numba's cache in the user's cache directory, one specialisation per argument types; nothing
is written at import) and serve every tube: the number of modules, the connector kinds and
the readings are arrays of
:class:`~.tables.SystemData`, which a :class:`System` holds writable and C-contiguous. Their
derivatives are written by hand from the element energies and checked against the JAX
autodiff oracle (:mod:`biplan.model.oracle`).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import Any

import numpy as np

from biplan._compile import numba_cache  # first: the kernels' cache locator
from biplan._compile.numba_cache import kernel_array
from biplan.geometry.layout import TubeLayout
from biplan.model.system import assemble, chainterm, ordering
from biplan.model.system import endpoint as free_end
from biplan.model.system.tables import SystemData, kernel_data, system_data
from biplan.model.tube import Tube

__all__ = ["System", "SystemData", "quiet_compile_notice", "system_data"]


@dataclass(frozen=True)
class System:
    """The KKT system r(z) = 0 of a tube at one load (MODEL §11), z = [q, λ, λ_∂, μ].

    Parameters
    ----------
    data : SystemData
        The tube as arrays (:func:`system_data`).
    load : ndarray (3,)
        (F [N], U [mm], d): end force, prescribed load-point displacement and 1.0 under
        displacement control (else 0.0).
    """

    data: SystemData
    load: np.ndarray

    def __post_init__(self) -> None:
        # writable, C-contiguous arrays only: one compiled signature per kernel
        object.__setattr__(self, "data", kernel_data(self.data))
        object.__setattr__(self, "load", kernel_array(self.load, float))

    @staticmethod
    def of(
        tube: Tube, force: float = 0.0, displacement: float = 0.0, control: float = 0.0
    ) -> System:
        """The system of a tube at a load."""
        dev = tube.development
        return System.of_numbers(
            tube.layout,
            dev.radius,
            dev.pitch,
            dev.beta,
            np.array([law.coefficients for law in tube.helical_laws], dtype=float),
            np.array([law.coefficients for law in tube.circular_laws], dtype=float).reshape(-1, 5),
        ).at(force, displacement, control)

    @staticmethod
    def of_numbers(
        layout: TubeLayout,
        radius: float,
        pitch: float,
        beta: float,
        helical: np.ndarray,
        circular: np.ndarray,
    ) -> System:
        """The system at rest of a layout with R, l [mm], β [rad] and the law rows (k1, k2, k3,
        w1, w2) of every helical (N, 5) and circular (Nc, 5) fold."""
        _announce_compile()
        data = system_data(layout, radius, pitch, beta, helical, circular)
        data = data._replace(load_reference=np.array([chainterm.reference_height(data)]))
        order, band = _solve_layout(layout, data)
        return System(data._replace(solve_order=order, solve_band=band), np.zeros(3))

    def with_contact(self, smoothing: float, compliance: float, smooth_min_width: float) -> System:
        """The system with other contact numbers: ε of the smoothed Fischer–Burmeister rows,
        the compliance c [mm/N] and the smooth minimum's τ [mm] (``ModelOptions``)."""
        scalars = self.data.scalars.copy()
        scalars[3:6] = smoothing, compliance, smooth_min_width
        return System(self.data._replace(scalars=scalars), self.load)

    def at(self, force: float = 0.0, displacement: float = 0.0, control: float = 0.0) -> System:
        """The same tube at another load."""
        return System(self.data, np.array([force, displacement, control], dtype=float))

    def with_bias(self, anchor: np.ndarray, stiffness: float) -> System:
        """The system whose Lagrangian carries the proximal bias ½κ‖q − q_a‖² [N·mm]."""
        data = self.data._replace(
            bias_anchor=np.asarray(anchor, dtype=float),
            bias_stiffness=np.array([float(stiffness)]),
        )
        return System(data, self.load)

    @property
    def sizes(self) -> tuple[int, int, int]:
        """(n_q, n_g, n_c)."""
        n_q, n_g, n_c = (int(v) for v in self.data.sizes)
        return n_q, n_g, n_c

    @property
    def n_unknowns(self) -> int:
        return sum(self.sizes) + 1

    def residual(self, z: np.ndarray) -> np.ndarray:
        """r(z) (n_z,)."""
        return assemble.residual(self.data, kernel_array(z, float), self.load)

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """∂r/∂z (n_z, n_z)."""
        return self.evaluate(z)[1]

    def evaluate(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(r, ∂r/∂z) at z in one pass (∂r/∂z written into NumPy's zeros: only the pages of
        its non-zero entries are touched, :func:`.assemble.evaluate_into`)."""
        z = kernel_array(z, float)
        jac = np.zeros((z.shape[0], z.shape[0]))
        out = assemble.evaluate_into(self.data, z, self.load, True, jac)
        return out[0], out[1]

    def endpoint(self, q: np.ndarray) -> tuple[float, float, float]:
        """(u_z [mm], u_r [mm], θ [rad]) of the free end relative to q = 0 (MODEL R2)."""
        u_z, u_r, theta = free_end.endpoint(self.data, kernel_array(q, float))
        return float(u_z), float(u_r), float(theta)

    def state(self, z: np.ndarray, jac: np.ndarray | None = None) -> Any:
        """The :class:`~biplan.model.lagrangian.StateData` at z (K, G and C taken from the KKT
        Jacobian ``jac`` at z when given, e.g. the one a Newton solve ends with)."""
        from biplan.geometry.chain import Endpoint
        from biplan.model.params import StateData

        z = kernel_array(z, float)
        n_q, n_g, n_c = self.sizes
        jac = self.jacobian(z) if jac is None else jac
        zp, a, e_hel, e_circ, gaps = assemble.observe(self.data, z)
        return StateData(
            energy=float(e_hel.sum() + e_circ.sum()),
            helical_energy=e_hel,
            circular_energy=e_circ,
            load_displacement=zp,
            endpoint=Endpoint(*self.endpoint(z[:n_q])),
            lagrangian_hessian=jac[:n_q, :n_q],
            constraint_jacobian=np.concatenate(
                [jac[n_q : n_q + n_g, :n_q], -jac[:n_q, n_q + n_g : n_q + n_g + n_c].T, a[None]]
            ),
            gaps=gaps,
        )


_ANNOUNCED: list[bool] = []
#: :func:`.ordering.solve_layout` of the layouts seen (structure only: one entry per layout).
_LAYOUTS: dict[TubeLayout, tuple[np.ndarray, np.ndarray]] = {}


def _solve_layout(layout: TubeLayout, data: SystemData) -> tuple[np.ndarray, np.ndarray]:
    """The layout's bordered banded solve order, computed once per layout and process."""
    found = _LAYOUTS.get(layout)
    if found is None:
        found = _LAYOUTS[layout] = ordering.solve_layout(data)
    return found


def quiet_compile_notice() -> None:
    """No one-time compile notice in this process (:func:`_announce_compile`): for a caller
    that says itself that the kernels compile (``biplan compile``'s workloads)."""
    _ANNOUNCED.append(True)


def _announce_compile() -> None:
    """Say on the terminal, once per process, that this install's kernels are compiling
    (:func:`biplan._compile.numba_cache.is_warm`): the first use after an install takes a few
    minutes (docs/performance.md, "One-time compile"), every later process loads them."""
    if _ANNOUNCED:
        return
    _ANNOUNCED.append(True)
    if not numba_cache.is_warm():
        print(
            "biplan: compiling the element kernels and solvers for this installation, once "
            "(a few minutes; `biplan compile` compiles all of them at once, in parallel; "
            f"cached in {numba_cache.cache_dir()})",
            file=sys.stderr,
            flush=True,
        )
