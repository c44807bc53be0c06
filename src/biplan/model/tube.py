"""A tube: N modules, their circular connectors and the assignment of fold laws (MODEL.md §5–6).

Modules alternate S, M, S, … starting from ``options.first_module`` (MODEL CHOICE K4). A
connector joins each pair of neighbours; with ``base_fold=True`` a circular fold also joins
module 1 to the flat clamp edge (semi-bistable design), otherwise module 1's frame is the clamp
frame (fully bistable design). Generalised coordinates::

    q = [u_1, φ1_1, φ2_1, …, u_N, φ1_N, φ2_N, γ_1, …, γ_Nc]     (main Eq. 2)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

from biplan._errors import ConfigError, check_integer
from biplan.geometry.connector import ConnectorSpec
from biplan.geometry.development import Development
from biplan.geometry.layout import FoldRef, TubeLayout
from biplan.geometry.module import module_shape
from biplan.laws import FoldLaw, LinearLaw, TrilinearLaw
from biplan.options import ModelOptions, ModuleKind

__all__ = ["FoldRef", "Tube", "TubeLayout", "initial_stiffness"]


def initial_stiffness(law: FoldLaw) -> float:
    """k1 [N/mm²]: the closed-branch (or only) stiffness of a law."""
    return law.stiffness if isinstance(law, LinearLaw) else law.stiffness[0]


@dataclass(frozen=True)
class Tube:
    """Geometry, topology and fold laws of a Mixed Folded Tube.

    Parameters
    ----------
    development : Development
        R, l, β of the crease network.
    n_modules : int
        N ≥ 1.
    helical_laws : tuple of FoldLaw
        One law per module (index 0 at the base).
    circular_laws : tuple of FoldLaw
        One law per circular fold: N − 1, plus one first for the base fold if ``base_fold``.
    base_fold : bool
        Whether a circular fold joins module 1 to the clamp.
    options : ModelOptions
        The readings the tube is modelled with (MODEL CHOICEs).
    surface_density : float
        Shell surface density μ [t/mm²] for the mass matrix (MODEL CHOICE D1), > 0.
    name : str
        Free label.
    """

    development: Development
    n_modules: int
    helical_laws: tuple[FoldLaw, ...]
    circular_laws: tuple[FoldLaw, ...]
    base_fold: bool = True
    options: ModelOptions = field(default_factory=ModelOptions)
    surface_density: float = 3.6e-10
    name: str = ""

    def __post_init__(self) -> None:
        n = check_integer("n_modules", self.n_modules, low=1)
        object.__setattr__(self, "n_modules", n)
        object.__setattr__(self, "helical_laws", tuple(self.helical_laws))
        object.__setattr__(self, "circular_laws", tuple(self.circular_laws))
        if len(self.helical_laws) != n:
            raise ConfigError("helical_laws", len(self.helical_laws), f"{n} laws (one per module)")
        nc = n - 1 + int(self.base_fold)
        if len(self.circular_laws) != nc:
            raise ConfigError(
                "circular_laws", len(self.circular_laws), f"{nc} laws (one per circular fold)"
            )
        for name, laws in (
            ("helical_laws", self.helical_laws),
            ("circular_laws", self.circular_laws),
        ):
            for i, law in enumerate(laws):
                if not isinstance(law, TrilinearLaw | LinearLaw):
                    raise ConfigError(f"{name}[{i}]", law, "a TrilinearLaw or LinearLaw")
        mu = self.surface_density
        if not (isinstance(mu, int | float) and math.isfinite(mu) and mu > 0):
            raise ConfigError("surface_density", mu, "a finite number > 0 t/mm²")
        if not isinstance(self.options, ModelOptions):
            raise ConfigError("options", self.options, "a ModelOptions")

    # --- construction helpers ------------------------------------------------------------
    @classmethod
    def uniform(
        cls,
        *,
        radius: float,
        pitch: float,
        helical_angle: float,
        n_modules: int,
        helical: FoldLaw,
        circular: FoldLaw,
        base_fold: bool = True,
        options: ModelOptions | None = None,
        **kwargs: Any,
    ) -> Tube:
        """A tube with one law for every helical fold and one for every circular fold."""
        dev = Development(radius, pitch, helical_angle)
        n = check_integer("n_modules", n_modules, low=1)
        return cls(
            dev,
            n,
            (helical,) * n,
            (circular,) * (n - 1 + int(base_fold)),
            base_fold,
            options or ModelOptions(),
            **kwargs,
        )

    def with_law(self, fold: FoldRef | tuple[str, int], law: FoldLaw) -> Tube:
        """Copy with the law of one fold replaced."""
        ref = fold if isinstance(fold, FoldRef) else FoldRef(*fold)
        name = {"helical": "helical_laws", "circular": "circular_laws"}.get(ref.set)
        if name is None:
            raise ConfigError("fold.set", ref.set, "'helical' or 'circular'")
        laws = list(getattr(self, name))
        if not 0 <= ref.index < len(laws):
            raise ConfigError("fold.index", ref.index, f"in [0, {len(laws) - 1}]")
        laws[ref.index] = law
        if name == "helical_laws":
            return replace(self, helical_laws=tuple(laws))
        return replace(self, circular_laws=tuple(laws))

    def with_options(self, **changes: Any) -> Tube:
        """Copy with some model readings changed (see :class:`ModelOptions`)."""
        return replace(self, options=self.options.with_(**changes))

    # --- derived quantities -------------------------------------------------------------
    @property
    def b(self) -> float:
        """Geometric ratio b = (l / cos β) / H (main Eq. basis)."""
        return self.development.b

    @property
    def C(self) -> float:
        """Stiffness ratio C = k_helic / k1_circ of the base-most helical and circular laws."""
        if not self.circular_laws:
            raise ConfigError("circular_laws", (), "at least one circular fold to define C")
        return initial_stiffness(self.helical_laws[0]) / initial_stiffness(self.circular_laws[0])

    @property
    def n_circular(self) -> int:
        """Number of circular folds N_c."""
        return len(self.circular_laws)

    @property
    def initial_length(self) -> float:
        """l_0 = N l [mm], the length of the fully closed tube."""
        return self.n_modules * self.development.pitch

    @property
    def module_kinds(self) -> tuple[ModuleKind, ...]:
        """S/M sequence from the base."""
        kinds = [self.options.first_module]
        for _ in range(self.n_modules - 1):
            kinds.append(kinds[-1].other())
        return tuple(kinds)

    @cached_property
    def layout(self) -> TubeLayout:
        """The static structure the model's kernels are compiled for."""
        shapes = tuple(module_shape(k, self.options.mirror) for k in self.module_kinds)
        conns: list[ConnectorSpec] = []
        h1_first = self.development.element1_span <= self.development.helical_span
        if self.base_fold:
            conns.append(ConnectorSpec(None, 0, None, shapes[0].bottom, h1_first))
        for n in range(1, self.n_modules):
            conns.append(ConnectorSpec(n - 1, n, shapes[n - 1].top, shapes[n].bottom, h1_first))
        return TubeLayout(self.n_modules, shapes, tuple(conns), self.options)

    def folds(self) -> tuple[FoldRef, ...]:
        """Every fold, helical then circular."""
        return tuple(FoldRef("helical", i) for i in range(self.n_modules)) + tuple(
            FoldRef("circular", i) for i in range(self.n_circular)
        )

    def law(self, fold: FoldRef) -> FoldLaw:
        """The law of one fold."""
        laws = self.helical_laws if fold.set == "helical" else self.circular_laws
        return laws[fold.index]
