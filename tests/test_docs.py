"""The documentation builds without warnings, lists every page, and the project metadata agrees.

``mkdocs build --strict`` turns every warning (a broken link, a missing snippet, a docstring
mkdocstrings cannot render, a page left out of the nav) into an error. The build needs the
``docs`` extra (``pip install -e ".[docs]"``, which ``make test`` installs); without it the
build test is skipped.
"""

from __future__ import annotations

import importlib.metadata
import re
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import pytest

import biplan

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _nav_pages(entry: Any) -> list[str]:
    """Every page file named in a (nested) mkdocs nav."""
    if isinstance(entry, str):
        return [entry]
    if isinstance(entry, list):
        return [p for item in entry for p in _nav_pages(item)]
    if isinstance(entry, dict):
        return [p for value in entry.values() for p in _nav_pages(value)]
    return []


def _mkdocs_config() -> dict[str, Any]:
    yaml = pytest.importorskip("yaml")
    return yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))


def test_mkdocs_build_strict(tmp_path: Path) -> None:
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    site = tmp_path / "site"
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,  # snippets (CHANGELOG.md, examples/*.py) resolve from the repository root
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stdout}\n{proc.stderr}"
    assert (site / "index.html").is_file()
    assert (site / "api" / "index.html").is_file()
    # The changelog page includes CHANGELOG.md through a snippet.
    assert "Keep a Changelog" in (site / "changelog.html").read_text(encoding="utf-8")


def test_every_page_is_in_the_nav() -> None:
    nav = _nav_pages(_mkdocs_config()["nav"])
    pages = {p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")}
    missing = sorted(pages - set(nav))
    assert not missing, f"pages not in the mkdocs.yml nav: {missing}"
    dangling = sorted(set(nav) - pages)
    assert not dangling, f"nav entries without a page: {dangling}"


def test_version_from_package_metadata() -> None:
    version = importlib.metadata.version("biplan")
    assert biplan.__version__ == version
    proc = subprocess.run(
        [sys.executable, "-m", "biplan", "--version"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert version in proc.stdout


def test_project_metadata_agrees() -> None:
    """pyproject, CITATION.cff, LICENSE and CHANGELOG state the same version and licence."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    yaml = pytest.importorskip("yaml")
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert citation["cff-version"] == "1.2.0"
    assert str(citation["version"]) == project["version"]
    assert citation["license"] == project["license"] == "MIT"
    assert citation["preferred-citation"]["authors"], "the paper's authors"
    assert (ROOT / "LICENSE").read_text(encoding="utf-8").startswith("MIT License")
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert re.search(rf"^## \[{re.escape(project['version'])}\]", changelog, re.MULTILINE)
