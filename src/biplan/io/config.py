"""TOML tube configuration (placeholder replaced below)."""

from __future__ import annotations

from pathlib import Path

from biplan.geometry import Tube


def load_config(path: str | Path) -> Tube:  # pragma: no cover - replaced
    raise NotImplementedError
