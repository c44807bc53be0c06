"""Single-branch (linear) fold law: k(w) = k (main text, semi-bistable helical folds)."""

from __future__ import annotations

from dataclasses import dataclass

from biplan._errors import ConfigError, check_finite
from biplan.laws._base import LawMixin

__all__ = ["LinearLaw"]

#: Breakpoints handed to the shared trilinear kernels; with k1 = k2 = k3 they do not matter.
_FAR = (1.0e6, 2.0e6)


@dataclass(frozen=True)
class LinearLaw(LawMixin):
    """Linear fold law: F(w) = k w [N/mm], Ψ(w) = k w²/2 [N].

    Parameters
    ----------
    stiffness : float
        k > 0 [N/mm²].
    """

    stiffness: float

    def __post_init__(self) -> None:
        k = check_finite("stiffness", self.stiffness)
        if k <= 0:
            raise ConfigError("stiffness", k, "> 0 N/mm²")
        object.__setattr__(self, "stiffness", k)

    @property
    def coefficients(self) -> tuple[float, float, float, float, float]:
        """(k, k, k, ·, ·): a trilinear law with equal slopes."""
        k = self.stiffness
        return (k, k, k, *_FAR)

    @property
    def is_bistable(self) -> bool:
        """Always False."""
        return False

    def wells(self) -> tuple[float, ...]:
        """The single zero-force elongation (0,)."""
        return (0.0,)

    def require_bistable(self, name: str = "law") -> LinearLaw:
        """Always raises: a linear law is never bistable."""
        raise ConfigError(name, self, "a bistable (trilinear) law, not a linear one")
