"""Headless Chromium for the explorer tests (Playwright driving Debian's ``chromium``).

The browser comes from ``scripts/install_browser.sh`` (run by ``make test``). Where it or
Playwright cannot be found or started, the tests that use the ``browser`` fixture
(conftest.py, :func:`launch`) are skipped with the reason in the summary and a warning.
"""

from __future__ import annotations

import io
import shutil
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

BROWSERS = ("chromium", "chromium-browser", "google-chrome")
#: Software WebGL for the 3D panels of a headless browser; no sandbox as root.
LAUNCH_ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]
#: Console messages that are not the page's errors (Chromium's notes on software WebGL).
HARMLESS = ("GPU stall due to ReadPixels", "Automatic fallback to software WebGL")


def _skip_loudly(reason: str) -> None:
    message = f"BROWSER TESTS SKIPPED: {reason} (run scripts/install_browser.sh)"
    warnings.warn(message, stacklevel=2)
    pytest.skip(message)


def launch() -> Iterator[Any]:
    """Yield a headless Chromium (the ``browser`` fixture of conftest.py), or skip loudly."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _skip_loudly("the playwright package is not installed (pip install -e '.[test]')")
    executable = next((shutil.which(b) for b in BROWSERS if shutil.which(b)), None)
    if executable is None:
        _skip_loudly("no Chromium on PATH")
    with sync_playwright() as p:
        try:
            chromium = p.chromium.launch(executable_path=executable, args=LAUNCH_ARGS)
        except Exception as err:
            _skip_loudly(f"Chromium at {executable} does not start: {err}")
        yield chromium
        chromium.close()


def open_page(browser: Any, file: Path) -> tuple[Any, list[str]]:
    page = browser.new_page(viewport={"width": 1400, "height": 1400})
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
    page.on(
        "console",
        lambda m: (
            errors.append(m.text)
            if m.type == "error" and not any(h in m.text for h in HARMLESS)
            else None
        ),
    )
    page.goto(file.as_uri())
    page.wait_for_selector("body[data-ready=true]", timeout=120_000)
    return page, errors


def not_blank(png: bytes) -> None:
    import matplotlib.image as mpimg

    pixels = mpimg.imread(io.BytesIO(png), format="png")[..., :3]
    assert pixels.std() > 0.05
    assert len(np.unique((pixels * 255).astype(np.uint8).reshape(-1, 3), axis=0)) > 50


def click_point(page: Any, div: str, x: float, y: float) -> None:
    """Click the data point (x, y) of a 2D Plotly figure, where a user would."""
    box = page.evaluate(
        """([div, x, y]) => {
            const gd = document.getElementById(div), L = gd._fullLayout;
            const r = gd.getBoundingClientRect();
            return [r.left + L._size.l + L.xaxis.l2p(x), r.top + L._size.t + L.yaxis.l2p(y)];
        }""",
        [div, x, y],
    )
    page.mouse.click(*box)
