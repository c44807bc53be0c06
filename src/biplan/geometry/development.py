"""Planar development of the cylinder (main text "Application"; MODEL.md §3).

(z, θ) on the cylinder of radius R maps to (z, s) with s = Rθ ∈ [0, H), H = 2πR. Circular folds
are lines z = const with pitch l; the helical fold of a module is a straight segment at angle β
to the axis spanning one pitch::

    a  = l / cos β        helical field length (SI Eq. 17)
    H2 = l tan β          circumferential extent of the helical segment (SI Eq. VC_w)
    H1 = H − H2           (requires H2 < H)
    b  = a / H            geometric ratio (main Eq. basis)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from biplan._compile.setup import array_module
from biplan._errors import ConfigError, check_range

__all__ = ["Development", "spans"]


def spans(radius, pitch, helical_angle_rad):  # type: ignore[no-untyped-def]
    """(H, H1, H2, a) [mm] from R [mm], l [mm] and β [rad]; JAX-traceable, NumPy for NumPy."""
    xp = array_module(radius, pitch, helical_angle_rad)
    h = 2.0 * xp.pi * radius
    h2 = pitch * xp.tan(helical_angle_rad)
    return h, h - h2, h2, pitch / xp.cos(helical_angle_rad)


@dataclass(frozen=True)
class Development:
    """Crease-network geometry of the development.

    Parameters
    ----------
    radius : float
        Tube radius R [mm], > 0.
    pitch : float
        Circular-fold pitch (module length) l [mm], > 0.
    helical_angle : float
        Helical-fold angle β to the tube axis [degrees], in (0, 90) and with l tan β < 2πR.
    """

    radius: float
    pitch: float
    helical_angle: float

    def __post_init__(self) -> None:
        r = check_range("radius", self.radius, low=0.0)
        p = check_range("pitch", self.pitch, low=0.0)
        b = check_range("helical_angle", self.helical_angle, low=0.0, high=90.0)
        object.__setattr__(self, "radius", r)
        object.__setattr__(self, "pitch", p)
        object.__setattr__(self, "helical_angle", b)
        h = 2 * math.pi * r
        if p * math.tan(math.radians(b)) >= h:
            limit = math.degrees(math.atan(h / p))
            raise ConfigError(
                "helical_angle",
                b,
                f"< {limit:.4g}° so that H2 = l tan β stays below the circumference H = {h:.4g} mm",
            )

    @property
    def beta(self) -> float:
        """β [rad]."""
        return math.radians(self.helical_angle)

    @property
    def circumference(self) -> float:
        """H = 2πR [mm]."""
        return 2 * math.pi * self.radius

    @property
    def helical_span(self) -> float:
        """H2 = l tan β [mm], circumferential extent of the helical fold (element 2's edge)."""
        return self.pitch * math.tan(self.beta)

    @property
    def element1_span(self) -> float:
        """H1 = H − H2 [mm], circumferential extent of element 1's split edge."""
        return self.circumference - self.helical_span

    @property
    def helical_length(self) -> float:
        """a = l / cos β [mm], length of the helical BiPlan field."""
        return self.pitch / math.cos(self.beta)

    @property
    def b(self) -> float:
        """Geometric ratio b = ℓ_helic / ℓ_circ = a / H (main Eq. basis)."""
        return self.helical_length / self.circumference

    @property
    def lock_displacement(self) -> float:
        """u_lim [mm]: the guide g_C = 0 has a solution only for |u| ≤ u_lim (MODEL §16)."""
        l, h, beta = self.pitch, self.circumference, self.beta
        return abs(l - (math.hypot(l, h) - h * math.sin(beta)) / math.cos(beta))

    @staticmethod
    def helical_angle_for_b(b: float, radius: float, pitch: float) -> float:
        """β [degrees] giving the geometric ratio ``b`` at fixed R and l (design-map sweeps)."""
        b = check_range("b", b, low=0.0)
        circumference = 2 * math.pi * radius
        bmin = pitch / circumference  # β = 0
        bmax = math.hypot(pitch, circumference) / circumference  # H2 = l tan β = H
        if not bmin < b < bmax:
            raise ConfigError(
                "b", b, f"in ({bmin:.4g}, {bmax:.4g}): > l/H (β = 0) and < √(l² + H²)/H "
                f"(H2 = l tan β reaches H) for R = {radius}, l = {pitch}",
            )  # fmt: skip
        return math.degrees(math.acos(pitch / (b * circumference)))
