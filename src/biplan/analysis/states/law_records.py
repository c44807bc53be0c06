"""Records of a fold-law search (:mod:`biplan.analysis.states.law_search`): one row per law set.

A :class:`LawRecords` holds, per law set, its ten coefficients and what its exhaustive state
search says about the paper's fully bistable tube (main Fig. 4, SI S11–S12): the number of
stable states (the paper's 34 of 128 seeds), which of the states the paper names (00, 2A, 1B,
66) are stable, the largest number of open helical folds among the stable states (three gives
slope levels in thirds), the largest distance of a slope branch's mean |Θ| from k/3, the |Θ|
at which the slope distribution peaks (paper: 1/3), the number of peaks of the elongation
distribution (paper: two), u_z/l₀, u_r/l₀ and Θ of 66 and 1B (paper: u_z/l₀ = 0.9, Θ = 0.67),
and the bits the seed of 66 relaxed to. Rows of invalid or failed law sets hold NaN / −1.

The arrays round-trip through :meth:`LawRecords.to_arrays` / :meth:`LawRecords.from_arrays`
(what a chunk store saves) and :meth:`LawRecords.rows` (CSV).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

__all__ = ["PAIR", "PAPER_N_STATES", "PAPER_STATES", "PAPER_SUB_BRANCH", "LawRecords", "LawStatus"]

#: The paper's number of stable states of the four-module fully bistable MFT (SI S11).
PAPER_N_STATES = 34
#: The paper's u_z/l0 of the iso-elongation sub-branch of 66 and 1B (main text, Fig. 4 B).
PAPER_SUB_BRANCH = 0.9
#: The paper's states named in the main text (Fig. 4 A–B).
PAPER_STATES = ("00", "2A", "1B", "66")
#: The two states on the paper's Θ = 0.67, u_z/l0 = 0.9 sub-branch (columns of the pair arrays).
PAIR = ("66", "1B")


class LawStatus(enum.Enum):
    """What happened to a law set."""

    OK = 0
    #: Not a pair of bistable trilinear laws (w1 ≥ w2, or a single well): not searched.
    INVALID = 1
    #: The state search raised.
    FAILED = 2


_INT = -1
_COLUMNS = {  # name → (dtype, extra shape, description)
    "values": (float, (10,), "law coefficients [N/mm², mm] (law_search.PARAMETERS)"),
    "status": (int, (), "LawStatus value"),
    "n_states": (int, (), "stable states (paper: 34)"),
    "n_labels": (int, (), "distinct labels among them"),
    "named": (int, (4,), "00, 2A, 1B, 66 stable (1) or not (0)"),
    "max_open_helical": (int, (), "most open helical folds of a stable state"),
    "thirds_error": (float, (), "max over branches k ≥ 1 of | |mean Θ| − k/3 |"),
    "slope_peak": (float, (), "|Θ| of the slope distribution's peak (paper: 1/3)"),
    "n_u_z_peaks": (int, (), "peaks of the u_z/l0 distribution (paper: 2)"),
    "u_z_rel": (float, (2,), "u_z/l0 of 66 and 1B (paper: 0.9)"),
    "u_r_rel": (float, (2,), "u_r/l0 of 66 and 1B"),
    "Theta": (float, (2,), "Θ of 66 and 1B (paper: 0.67)"),
    "seed_66_reached": (int, (), "bits (as an integer) the seed of 66 relaxed to; −1 failed"),
    "n_failed_seeds": (int, (), "seeds whose relaxation failed"),
    "n_unstable_seeds": (int, (), "seeds that reached an unstable equilibrium"),
    "helical_well": (float, (), "open well of the helical law [mm]"),
    "circular_well": (float, (), "open well of the circular law [mm]"),
    "seconds": (float, (), "wall time of the law set [s]"),
}


@dataclass(frozen=True)
class LawRecords:
    """Rows of a law search, one per law set (module docstring; attributes as named there,
    each an array with the row axis first)."""

    values: np.ndarray
    status: np.ndarray
    n_states: np.ndarray
    n_labels: np.ndarray
    named: np.ndarray
    max_open_helical: np.ndarray
    thirds_error: np.ndarray
    slope_peak: np.ndarray
    n_u_z_peaks: np.ndarray
    u_z_rel: np.ndarray
    u_r_rel: np.ndarray
    Theta: np.ndarray
    seed_66_reached: np.ndarray
    n_failed_seeds: np.ndarray
    n_unstable_seeds: np.ndarray
    helical_well: np.ndarray
    circular_well: np.ndarray
    seconds: np.ndarray

    @classmethod
    def empty(cls, n: int) -> LawRecords:
        """``n`` rows of NaN (floats) and −1 (integers)."""
        return cls(
            **{
                k: np.full((n, *shape), np.nan if dtype is float else _INT, dtype=dtype)
                for k, (dtype, shape, _) in _COLUMNS.items()
            }
        )

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> LawRecords:
        """Rows from :meth:`to_arrays` (e.g. a chunk store's chunk)."""
        return cls(
            **{k: np.asarray(arrays[k], dtype=dtype) for k, (dtype, _, _) in _COLUMNS.items()}
        )

    @classmethod
    def concatenate(cls, parts: list[LawRecords]) -> LawRecords:
        """The rows of ``parts`` one after the other."""
        if not parts:
            return cls.empty(0)
        return cls(**{k: np.concatenate([getattr(p, k) for p in parts]) for k in _COLUMNS})

    def to_arrays(self) -> dict[str, np.ndarray]:
        """name → array (row axis first)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def take(self, index: Any) -> LawRecords:
        """The rows ``index`` (an index array or a mask)."""
        return LawRecords(**{k: getattr(self, k)[index] for k in _COLUMNS})

    def __len__(self) -> int:
        return len(self.status)

    @property
    def ok(self) -> np.ndarray:
        """Rows whose state search ran."""
        return self.status == LawStatus.OK.value

    @property
    def n_named(self) -> np.ndarray:
        """How many of 00, 2A, 1B, 66 are stable (−1: not searched)."""
        return np.where(self.ok, self.named.sum(axis=1), -1)

    def rows(self, parameters: tuple[str, ...]) -> list[dict[str, object]]:
        """One flat dict per row (CSV): the coefficients by name, then every record field."""
        out = []
        for i in range(len(self)):
            row: dict[str, object] = dict(zip(parameters, self.values[i].tolist(), strict=True))
            row["status"] = LawStatus(int(self.status[i])).name.lower()
            for k in _COLUMNS:
                if k in ("values", "status"):
                    continue
                a = getattr(self, k)[i]
                if k == "named":
                    row.update(
                        {f"stable_{s}": int(b) for s, b in zip(PAPER_STATES, a, strict=True)}
                    )
                elif a.ndim:
                    row.update({f"{k}_{s}": float(x) for s, x in zip(PAIR, a, strict=True)})
                elif k == "seed_66_reached":
                    row[k] = f"{int(a):02X}" if a >= 0 else ""  # the label (seven bits)
                else:
                    row[k] = a.item()
            out.append(row)
        return out
