"""Model readings: every place MODEL.md marks CHOICE, as one frozen options object.

The paper is ambiguous in several places; each reading is an enum member here so that users
can compare them (``docs/fidelity.md``). Defaults follow MODEL.md unless ``docs/`` says why not.

==============  ===========================================  ==================================
MODEL CHOICE    field                                         default
==============  ===========================================  ==================================
L1              ``transition_reading``                        breakpoints are absolute
K3              ``mirror``                                    reflection z → l − z
K4              ``first_module``                              standard (S) module at the base
C1              ``contact``                                   one condition per field endpoint
R1              ``chain_offset``                              exact seam gap γ
R3              ``chain_attachment``                          SPC: lower element; TPC: translation
R2              ``endpoint``                                  free-end edge, least squares
W1              ``load_point``                                centroid of the free-end edge
S1              ``weak_contacts_active``                      False (conservative)
V1              ``tpc_sign``                                  geometric (SI sign flipped, §7)
==============  ===========================================  ==================================
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, fields, replace
from typing import Any

from biplan._errors import ConfigError, check_range

__all__ = [
    "ChainAttachment",
    "ChainOffset",
    "ContactForm",
    "EndpointDefinition",
    "LoadPoint",
    "MirrorConvention",
    "ModelOptions",
    "ModuleKind",
    "TpcSign",
    "TransitionReading",
]


class TransitionReading(enum.Enum):
    """How the calibration table's ``l_circ = [l1, l2]`` becomes breakpoints (MODEL CHOICE L1).

    ``ABSOLUTE``: the breakpoints are the elongations w1 = l1, w2 = l2 at which the branches
    change (default: the SI interpolates the spinodal "between the two measured instability
    points"). ``BRANCH_LENGTHS``: l1 is the closed-branch length and l2 the spinodal length,
    so w1 = l1 and w2 = l1 + l2.
    """

    ABSOLUTE = "absolute"
    BRANCH_LENGTHS = "branch_lengths"


class ModuleKind(enum.Enum):
    """Standard (S) or mirrored (M) module (MODEL §5)."""

    STANDARD = "standard"
    MIRRORED = "mirrored"

    def other(self) -> ModuleKind:
        """The opposite kind (modules alternate S, M, S, …)."""
        return ModuleKind.MIRRORED if self is ModuleKind.STANDARD else ModuleKind.STANDARD


class MirrorConvention(enum.Enum):
    """How the mirrored module is obtained from the standard one (MODEL CHOICE K3).

    ``REFLECTION``: mirror about z = l/2 (helical folds form a zig-zag; every open helical fold
    tilts the tube the same way). ``POINT``: 180° rotation (the SI's literal n_sp → −n_sp,
    n_c → −n_c; a continuous helix).
    """

    REFLECTION = "reflection"
    POINT = "point"


class ContactForm(enum.Enum):
    """Contact on circular connectors (MODEL CHOICE C1).

    ``PER_ENDPOINT``: one smoothed Fischer–Burmeister condition per field endpoint.
    ``MINIMUM``: the SI's single condition on the smallest boundary elongation, with a
    smooth minimum of width ``smooth_min_width``.
    """

    PER_ENDPOINT = "per_endpoint"
    MINIMUM = "minimum"


class ChainOffset(enum.Enum):
    """Translation between neighbouring module frames (MODEL CHOICE R1).

    ``EXACT``: the seam gap equals γ exactly (consistent with the connector energy).
    ``PAPER``: the SI's literal a_m = Δ_m [1, tan θ_m], Δ_m = γ_m − u_m + l.
    """

    EXACT = "exact"
    PAPER = "paper"


class ChainAttachment(enum.Enum):
    """How the frame of a module follows the module below it (MODEL §16, reading R3).

    ``ELEMENT``: the paper's chain — across an SPC the module above rides on the lower
    module's full top element (H^SPC = its rotation), across a TPC it is only translated
    (H^TPC = I). Only S-module helical openings then rotate the downstream tube.
    ``EDGE_FIT``: edge-fit stacking — each module's frame is placed so that the least-squares
    rigid fit of its bottom edge (length-weighted, the fit that defines the endpoint slope θ)
    sits γ above the fit of the lower module's top edge. A module whose helical opening tilts
    its own bottom edge (an M module) then rotates its body, and everything above it, the
    other way, so every open helical fold rotates the downstream tube. The seam gap is γ
    between the fitted edges (the ``ChainOffset`` reading does not apply). Only the
    reconstruction (endpoint, load height) changes: fold elongations, energy and stability
    at zero end load are the same.
    """

    ELEMENT = "element"
    EDGE_FIT = "edge_fit"


class EndpointDefinition(enum.Enum):
    """What "the endpoint" is (MODEL CHOICE R2).

    ``EDGE``: length-weighted mean and least-squares tilt of the free-end edge.
    ``SEAM_NODE``: the seam point of the free-end edge, slope of the element holding it.
    """

    EDGE = "edge"
    SEAM_NODE = "seam_node"


class LoadPoint(enum.Enum):
    """Where the dead axial end force acts (MODEL CHOICE W1).

    ``CENTROID``: centroid of the free-end edge (pneumatic end-cap resultant).
    ``SEAM``: the seam point of the free-end edge. ``SPLIT``: the end edge's split point
    s = H1 (an eccentric point load).
    """

    CENTROID = "centroid"
    SEAM = "seam"
    SPLIT = "split"


class TpcSign(enum.Enum):
    """Sign of the x-dependent part of a TPC's first field (MODEL §7, SI Eq. VC_w).

    ``GEOMETRIC``: w₁(x) = γ − x [tan φ₁⁽ˢ⁾ − tan φ₁⁽ᴹ⁾], the axial gap of the two edge lines
    (consistent with the element geometry, as the second field and the SPC are).
    ``AS_PRINTED``: the SI's printed w₁(x) = γ + x [tan φ₁⁽ˢ⁾ − tan φ₁⁽ᴹ⁾]. Inconsistent with
    the element geometry: the two fields of a TPC then disagree by 2|x (tan φ₁⁽ˢ⁾ − tan φ₁⁽ᴹ⁾)|
    at their shared split point. Selectable because the paper's maps may have been computed
    with it (docs/fidelity.md, "The printed TPC sign").
    """

    GEOMETRIC = "geometric"
    AS_PRINTED = "as_printed"


_ENUMS: dict[str, type[enum.Enum]] = {
    "transition_reading": TransitionReading,
    "mirror": MirrorConvention,
    "first_module": ModuleKind,
    "contact": ContactForm,
    "chain_offset": ChainOffset,
    "chain_attachment": ChainAttachment,
    "endpoint": EndpointDefinition,
    "load_point": LoadPoint,
    "tpc_sign": TpcSign,
}


@dataclass(frozen=True)
class ModelOptions:
    """The selectable readings of the BiPlan model (see module docstring for the table).

    Parameters
    ----------
    transition_reading, mirror, first_module, contact, chain_offset, chain_attachment,
        endpoint, load_point, tpc_sign
        Enum members or their string values.
    weak_contacts_active : bool
        Treat contacts with λ_∂ ≈ 0 and w ≈ 0 as active in the stability test (S1).
    contact_smoothing : float
        ε of the smoothed Fischer–Burmeister function (SI Eq. sfb), > 0.
    contact_compliance : float
        c [mm/N] ≥ 0 of the contact rows φ_ε(w_∂ + c λ_∂, λ_∂) = 0: a contact carrying λ_∂
        may close past flat by c λ_∂. With c = 0 (the SI's rows) a contact whose gap is
        held at zero by the kinematics (the start of a closed helical fold) has no finite
        smoothed multiplier; c > 0 bounds it by ε/√(2c)
        (docs/model.md, "Degenerate contacts").
    smooth_min_width : float
        τ [mm] of the smooth minimum used by ``ContactForm.MINIMUM``, > 0.
    """

    transition_reading: TransitionReading = TransitionReading.ABSOLUTE
    mirror: MirrorConvention = MirrorConvention.REFLECTION
    first_module: ModuleKind = ModuleKind.STANDARD
    contact: ContactForm = ContactForm.PER_ENDPOINT
    chain_offset: ChainOffset = ChainOffset.EXACT
    chain_attachment: ChainAttachment = ChainAttachment.ELEMENT
    endpoint: EndpointDefinition = EndpointDefinition.EDGE
    load_point: LoadPoint = LoadPoint.CENTROID
    tpc_sign: TpcSign = TpcSign.GEOMETRIC
    weak_contacts_active: bool = False
    contact_smoothing: float = 1e-6
    smooth_min_width: float = 1e-3
    contact_compliance: float = 1e-6

    def __post_init__(self) -> None:
        for name, cls in _ENUMS.items():
            value = getattr(self, name)
            if not isinstance(value, cls):
                try:
                    object.__setattr__(self, name, cls(value))
                except ValueError:
                    valid = ", ".join(repr(m.value) for m in cls)  # type: ignore[attr-defined]
                    raise ConfigError(f"options.{name}", value, f"one of {valid}") from None
        if not isinstance(self.weak_contacts_active, bool):
            raise ConfigError("options.weak_contacts_active", self.weak_contacts_active, "a bool")
        for name in ("contact_smoothing", "smooth_min_width"):
            object.__setattr__(
                self, name, check_range(f"options.{name}", getattr(self, name), low=0.0, high=1.0)
            )
        object.__setattr__(
            self,
            "contact_compliance",
            check_range(
                "options.contact_compliance",
                self.contact_compliance,
                low=0.0,
                high=1e-3,
                low_open=False,
            ),
        )

    def with_(self, **changes: Any) -> ModelOptions:
        """Return a copy with some readings changed (validated)."""
        names = {f.name for f in fields(self)}
        for key in changes:
            if key not in names:
                raise ConfigError("options", key, f"one of {sorted(names)}")
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain-value dict (enum values as strings), e.g. for result metadata."""
        out: dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            out[f.name] = v.value if isinstance(v, enum.Enum) else v
        return out
