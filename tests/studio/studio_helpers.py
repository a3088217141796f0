"""What the browser tests share: screenshots into docs/images, plans compared point for point."""

from __future__ import annotations

import os
import tempfile
import threading
from pathlib import Path

import numpy as np
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

#: Where the screenshots go: docs/images for the README with PENCILBOT_SCREENSHOTS=1, else a
#: temporary folder (a test run leaves the tree as it was).
SCREENSHOTS = (
    Path(__file__).resolve().parents[2] / "docs" / "images"
    if os.environ.get("PENCILBOT_SCREENSHOTS")
    else Path(tempfile.gettempdir()) / "pencilbot-studio-screenshots"
)


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
    return all(
        x.name == y.name
        and x.pen_width == y.pen_width
        and np.array_equal(x.paths.offsets, y.paths.offsets)
        and np.allclose(x.paths.points, y.paths.points, atol=1e-6)
        for x, y in zip(a.layers, b.layers)
    )


WAIT = 90  # s: a loaded machine plans slowly; these are waits for a state, not timing checks


def text(browser, element_id: str) -> str:
    return browser.find_element(By.ID, element_id).text


def wait_for(browser, condition, what: str):
    return WebDriverWait(browser, WAIT, poll_frequency=0.1).until(lambda _: condition(), message=what)


def set_control(browser, element_id: str, value) -> None:
    """Move a slider or pick an option as a person does: the value, then the input event."""
    browser.execute_script(
        "const e = document.getElementById(arguments[0]); e.value = arguments[1];"
        "e.dispatchEvent(new Event('input', {bubbles: true}));",
        element_id,
        str(value),
    )


def full_generation(browser) -> int:
    stage = browser.find_element(By.ID, "preview-stage")
    if not stage.text.startswith("full"):
        return 0
    return int(stage.get_attribute("data-generation") or 0)


def load_photo(server, browser, photo) -> int:
    browser.get(server.url)
    wait_for(browser, lambda: text(browser, "connection") == "connected", "the page connects")
    browser.find_element(By.ID, "photo-input").send_keys(str(photo))
    return wait_for(browser, lambda: full_generation(browser), "the full preview of the photo")


def serving(running) -> threading.Thread:
    """Serve ``running`` in a thread; back once uvicorn listens (a 10 s bound)."""
    thread = threading.Thread(target=running.serve, name="studio server", daemon=True)
    thread.start()
    for _ in range(200):
        if running.server.started:
            break
        threading.Event().wait(0.05)
    return thread


def sheet_pixels(browser, condition: str) -> int:
    """Pixels of the sheet's canvas for which ``condition`` (JS over r, g, b, a) holds."""
    return browser.execute_script(
        "const c = document.getElementById('sheet'); const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
        f"let n = 0; for (let i = 0; i < d.length; i += 4) {{ const r = d[i], g = d[i + 1], b = d[i + 2], a = d[i + 3]; if ({condition}) n++; }} return n;"
    )


def viewport(browser, width: int, height: int) -> None:
    """The page's viewport at exactly ``width`` × ``height`` CSS px (a phone's with touch)."""
    browser.execute_cdp_cmd(
        "Emulation.setDeviceMetricsOverride",
        {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": width < 500},
    )
