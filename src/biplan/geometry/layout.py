"""The static structure of a tube: the modules, their connectors and fold names (MODEL.md §5–6).

:class:`TubeLayout` is what a compiled kernel is specialised for (hashable, no fold laws, no
numbers that change between designs of one layout); :class:`FoldRef` names one fold.
"""

from __future__ import annotations

from dataclasses import dataclass

from biplan.geometry.connector import ConnectorSpec
from biplan.geometry.module import ModuleShape
from biplan.options import ModelOptions


@dataclass(frozen=True)
class FoldRef:
    """A fold of the tube: ``set`` is ``"helical"`` or ``"circular"``; ``index`` counts from 0
    at the base (helical: module index; circular: connector index, the base fold first)."""

    set: str
    index: int


@dataclass(frozen=True)
class TubeLayout:
    """Static, hashable structure of a tube: what a jitted kernel is compiled for."""

    n_modules: int
    shapes: tuple[ModuleShape, ...]
    connectors: tuple[ConnectorSpec, ...]
    options: ModelOptions

    @property
    def n_connectors(self) -> int:
        return len(self.connectors)

    @property
    def n_coordinates(self) -> int:
        """n_q = 3N + N_c."""
        return 3 * self.n_modules + self.n_connectors

    @property
    def has_base_connector(self) -> bool:
        return bool(self.connectors) and self.connectors[0].lower is None

    def fold_name(self, fold: FoldRef) -> str:
        """The name of a fold in every file, figure and message: modules count from 1 at the
        base, so ``"helical 1"`` … ``"helical N"`` and ``"circular 0|1"`` (the base fold,
        between the clamp and module 1), ``"circular 1|2"`` … ``"circular N-1|N"``."""
        if fold.set == "helical":
            return f"helical {fold.index + 1}"
        c = self.connectors[fold.index]
        return f"circular {0 if c.lower is None else c.lower + 1}|{c.upper + 1}"

    @property
    def fold_names(self) -> tuple[str, ...]:
        """:meth:`fold_name` of every fold, helical then circular (the kernels' fold order)."""
        folds = [FoldRef("helical", i) for i in range(self.n_modules)]
        folds += [FoldRef("circular", c) for c in range(self.n_connectors)]
        return tuple(self.fold_name(f) for f in folds)
