"""Each state of the studio at a desktop's 1280×800 and a phone's 390×844, as screenshots
(docs/images/studio-ws-*.png with PENCILBOT_SCREENSHOTS=1): the empty page, a photo loaded, the
preview zoomed to the pen, plotting with its progress, the pen-change dialog, dark mode. At each
size the page is no wider than the screen and nothing of it is cut off sideways."""

from __future__ import annotations

import io

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select
from studio_helpers import SCREENSHOTS, full_generation, load_photo, text, viewport, wait_for

SIZES = {"desktop": (1280, 800), "phone": (390, 844)}


def shot(browser, name: str, zoom: bool = False) -> None:
    """studio-ws-NAME-desktop.png and -phone.png: the page at each size, small PNGs (≤ 150 kB)."""
    from PIL import Image

    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    for size, (width, height) in SIZES.items():
        viewport(browser, width, height)
        browser.execute_script("fitView(); if (arguments[0]) penScale();", zoom)
        if size == "phone":
            browser.execute_script("document.getElementById('look').scrollIntoView()")
        wide = browser.execute_script("return document.documentElement.scrollWidth")
        assert wide <= width, f"{name}: the page is {wide} px wide on a {width} px screen"
        page = Image.open(io.BytesIO(browser.get_screenshot_as_png())).convert("RGB")
        small = page.quantize(colors=96, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
        path = SCREENSHOTS / f"studio-ws-{name}-{size}.png"
        small.save(path, optimize=True)
        assert path.stat().st_size < 150_000, f"{path.name} is {path.stat().st_size} bytes"
        browser.execute_script("window.scrollTo(0, 0)")
    viewport(browser, *SIZES["desktop"])


def plotting(server) -> dict:
    plot = server.studio.plotters.sessions.get("sim://")
    return {} if plot is None else {**plot.record, "active": plot.active, "prompt": plot.prompt}


def job_shown(browser) -> bool:
    return browser.execute_script(
        "const p = plotOf('sim://'); return !!p && sheet.jobKey === `${p.port} ${p.started}`"
    )


def stop_plot(server, browser) -> None:
    if plotting(server).get("active"):
        dialog = browser.find_element(By.ID, "prompt")
        browser.find_element(By.ID, "prompt-stop" if dialog.is_displayed() else "stop").click()
        wait_for(browser, lambda: not plotting(server).get("active"), "the plot stopped")


def test_screenshots_of_each_state_at_desktop_and_phone_size(server, browser, photo):
    browser.get(server.url)
    wait_for(browser, lambda: text(browser, "connection") == "connected", "the page connects")
    shot(browser, "1-empty")
    load_photo(server, browser, photo)
    wait_for(browser, lambda: browser.execute_script("return !!sheet.plan"), "the plan on the sheet")
    shot(browser, "2-photo")
    browser.find_element(By.ID, "zoom-pen").click()
    shot(browser, "3-zoomed", zoom=True)
    browser.find_element(By.ID, "zoom-fit").click()
    browser.execute_script("setTheme('dark')")
    try:
        shot(browser, "6-dark")
    finally:
        browser.execute_script("setTheme('auto')")

    Select(browser.find_element(By.ID, "port")).select_by_value("sim://")
    browser.find_element(By.ID, "plot-start").click()
    wait_for(browser, lambda: (plotting(server).get("running") or 0) > 400, "the machine draws a while")
    wait_for(browser, lambda: text(browser, "plot-status").startswith("plotting"), "the page says so")
    wait_for(browser, lambda: job_shown(browser), "the plot on the sheet")
    shot(browser, "4-plotting")
    stop_plot(server, browser)

    before = full_generation(browser)
    Select(browser.find_element(By.ID, "pens")).select_by_value("cmyk")
    wait_for(browser, lambda: full_generation(browser) > before, "the cmyk plan")
    browser.find_element(By.ID, "plot-start").click()
    wait_for(browser, lambda: browser.find_element(By.ID, "prompt").is_displayed(), "the pen change")
    wait_for(browser, lambda: job_shown(browser), "the plot on the sheet")
    shot(browser, "5-pen-change")
    stop_plot(server, browser)

    assert full_generation(browser)


pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")
