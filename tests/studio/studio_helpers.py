"""What the browser tests share: screenshots into docs/images, plans compared point for point."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

#: Where the screenshots go: docs/images for the README with PENCILBOT_SCREENSHOTS=1, else a
#: temporary folder (a test run leaves the tree as it was).
SCREENSHOTS = (Path(__file__).resolve().parents[2] / "docs" / "images" if os.environ.get("PENCILBOT_SCREENSHOTS")
               else Path(tempfile.gettempdir()) / "pencilbot-studio-screenshots")


def screenshot(browser, name: str) -> None:
    """docs/images/studio-NAME.png: the page as it is now."""
    import io

    from PIL import Image

    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    page = Image.open(io.BytesIO(browser.get_screenshot_as_png())).convert("RGB")
    small = page.resize((page.width * 3 // 4, page.height * 3 // 4), Image.LANCZOS).quantize(colors=128)
    small.save(SCREENSHOTS / f"studio-{name}.png", optimize=True)


def same_plan(a, b) -> bool:
    """Two plans with the same page and the same layers, point for point (to the SVG's rounding)."""
    if (a.page.width, a.page.height) != (b.page.width, b.page.height) or len(a.layers) != len(b.layers):
        return False
    return all(x.name == y.name and x.pen_width == y.pen_width and np.array_equal(x.paths.offsets, y.paths.offsets)
               and np.allclose(x.paths.points, y.paths.points, atol=1e-6) for x, y in zip(a.layers, b.layers))
