"""The sheet in a real headless Chromium: the paper to scale (a landscape drawing on a landscape
sheet), zoom by buttons, wheel, keys and pinch down to the pen's width, the drawing dragged and
scaled into place (and plotted where it is shown), a custom paper size, layers shown or skipped."""

from __future__ import annotations

import numpy as np
import pytest
from selenium.common.exceptions import StaleElementReferenceException
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from selenium.webdriver.support.ui import Select
from studio_helpers import full_generation, load_photo, set_control, sheet_pixels, text, wait_for

from pencilbot.errors import PencilbotError

PAPER = "a > 0 && r > 250 && g > 250 && b > 250"  # the white sheet (the desk around it is grey)


def paper_box(browser) -> tuple[int, int]:
    """Width and height (canvas px) of the white paper on the sheet."""
    return tuple(
        browser.execute_script(
            "const c = document.getElementById('sheet'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
            "let x0 = 1e9, x1 = -1, y0 = 1e9, y1 = -1;"
            "for (let y = 0; y < c.height; y++) for (let x = 0; x < c.width; x++) { const i = 4 * (y * c.width + x);"
            " if (d[i] > 250 && d[i + 1] > 250 && d[i + 2] > 250) { x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y); } }"
            "return [x1 - x0 + 1, y1 - y0 + 1];"
        )
    )


def scale(browser) -> float:
    return browser.execute_script("return sheet.view.s")


def plan_ready(browser) -> bool:
    return browser.execute_script(
        "return !!sheet.plan && sheet.plan.generation === state.generation && sheet.view !== null"
    )


def newest_plan_shown(server, browser) -> bool:
    """The server's newest generation planned in full and on the sheet: an earlier test's change
    (the page back to A4) may still be planning when the next test starts."""
    try:
        server.studio.raw_plan()
    except PencilbotError:
        return False
    shown = browser.execute_script("return state.generation")
    return shown == server.studio.planner.generation and plan_ready(browser)


def steady_ink(browser, condition: str, seen: list) -> int | None:
    """``sheet_pixels`` once two reads in a row agree (the sheet is drawn on animation frames)."""
    seen.append(sheet_pixels(browser, condition))
    return seen[-1] if len(seen) > 1 and seen[-1] == seen[-2] else None


def test_the_landscape_drawing_lies_on_a_landscape_sheet_with_its_outline(server, browser, photo):
    load_photo(server, browser, photo)
    wait_for(browser, lambda: plan_ready(browser), "the plan's paths on the sheet")
    width, height = paper_box(browser)
    assert abs(width / height - 297 / 210) < 0.03  # A4 turned for the landscape photo, to scale
    ink = sheet_pixels(browser, "a > 0 && r < 80 && g < 80 && b < 80")
    assert ink > 2000  # the plan drawn over the paper
    assert browser.find_element(By.ID, "sheet").size["height"] > 300  # one large drawing area


def test_zoom_by_buttons_wheel_keys_and_pinch_down_to_the_pen(server, browser, photo):
    if not full_generation(browser):
        load_photo(server, browser, photo)
    wait_for(browser, lambda: plan_ready(browser), "the plan on the sheet")
    browser.find_element(By.ID, "zoom-fit").click()
    fit = scale(browser)
    browser.find_element(By.ID, "zoom-in").click()
    assert scale(browser) == pytest.approx(fit * 1.5)
    browser.find_element(By.ID, "zoom-pen").click()
    pen = browser.execute_script("return Math.min(...sheet.plan.layers.map((l) => l.width))")
    assert scale(browser) * pen >= 10  # the pen's line is ten pixels wide and more: pen scale
    sheet = browser.find_element(By.ID, "sheet")
    sheet.click()
    sheet.send_keys("0")
    assert scale(browser) == pytest.approx(fit)
    sheet.send_keys("+")
    assert scale(browser) == pytest.approx(fit * 1.5)
    sheet.send_keys("-")
    at = scale(browser)
    ActionChains(browser).scroll_from_origin(ScrollOrigin.from_element(sheet), 0, -300).perform()
    wait_for(browser, lambda: scale(browser) > at * 1.2, "the wheel zooms in")
    before = browser.execute_script("return {...sheet.view}")
    sheet.send_keys(Keys.ARROW_LEFT)
    assert browser.execute_script("return sheet.view.ox") == pytest.approx(before["ox"] + 40)

    at = scale(browser)
    box = browser.execute_script(
        "const r = document.getElementById('sheet').getBoundingClientRect(); return [r.left, r.top, r.width, r.height]"
    )
    cx, cy = box[0] + box[2] / 2, box[1] + box[3] / 2

    def touch(kind: str, spread: float) -> None:
        points = [{"x": cx - spread, "y": cy, "id": 1}, {"x": cx + spread, "y": cy, "id": 2}]
        browser.execute_cdp_cmd(
            "Input.dispatchTouchEvent", {"type": kind, "touchPoints": [] if kind == "touchEnd" else points}
        )

    touch("touchStart", 20)
    for spread in (30, 45, 60):
        touch("touchMove", spread)
    touch("touchEnd", 60)
    assert scale(browser) == pytest.approx(at * 3, rel=0.1)  # fingers three times as far apart


def test_dragging_the_drawing_places_it_where_it_is_plotted(server, browser, photo):
    if not full_generation(browser):
        load_photo(server, browser, photo)
    wait_for(browser, lambda: plan_ready(browser), "the plan on the sheet")
    browser.find_element(By.ID, "place-reset").click()
    wait_for(
        browser, lambda: server.studio.placement.dx == 0 and server.studio.placement.scale == 1, "centred"
    )
    browser.find_element(By.ID, "zoom-fit").click()
    s = scale(browser)
    ActionChains(browser).move_to_element(
        browser.find_element(By.ID, "sheet")
    ).click_and_hold().move_by_offset(60, 30).release().perform()
    wait_for(browser, lambda: server.studio.placement.dx != 0, "the placement reaches the server")
    where = server.studio.placement
    assert where.dx == pytest.approx(60 / s, abs=0.3) and where.dy == pytest.approx(-30 / s, abs=0.3)
    assert browser.find_element(By.ID, "place-dx").get_attribute("value") == f"{where.dx:g}"
    raw, placed = server.studio.raw_plan(), server.studio.full_plan()
    shift = placed.layers[0].paths.points - raw.layers[0].paths.points
    assert np.allclose(shift, (where.dx, where.dy))  # what goes to the plotter moved as shown

    set_control(browser, "place-scale", 50)
    wait_for(browser, lambda: server.studio.placement.scale == 0.5, "half size")
    placed = server.studio.full_plan().paths().points
    raw = server.studio.raw_plan().paths().points
    assert np.ptp(placed, axis=0) == pytest.approx(np.ptp(raw, axis=0) / 2, rel=1e-6)
    browser.find_element(By.ID, "place-reset").click()
    wait_for(
        browser, lambda: server.studio.placement.scale == 1 and server.studio.placement.dx == 0, "centred"
    )


def test_a_custom_paper_size_is_planned_and_drawn_to_scale(server, browser, photo):
    before = full_generation(browser) or load_photo(server, browser, photo)
    Select(browser.find_element(By.ID, "page")).select_by_value("custom")
    assert browser.find_element(By.ID, "page_w").is_displayed()
    set_control(browser, "page_w", 400)
    set_control(browser, "page_h", 150)
    wait_for(browser, lambda: server.studio.options.page == "400x150", "the custom page reaches the server")
    wait_for(browser, lambda: full_generation(browser) > before and plan_ready(browser), "the plan on it")
    assert (server.studio.raw_plan().page.width, server.studio.raw_plan().page.height) == (400, 150)
    width, height = paper_box(browser)
    assert abs(width / height - 400 / 150) < 0.05
    Select(browser.find_element(By.ID, "page")).select_by_value("A4")
    wait_for(browser, lambda: server.studio.options.page == "A4", "back to A4")


def test_a_skipped_layer_is_shown_faint_and_not_plotted_a_hidden_one_not_shown(server, browser, photo):
    if not full_generation(browser):
        load_photo(server, browser, photo)
    wait_for(browser, lambda: newest_plan_shown(server, browser), "the newest plan on the sheet")
    wait_for(browser, lambda: browser.find_elements(By.CSS_SELECTOR, "#layers .layer"), "the layer list")
    name = browser.find_elements(By.CSS_SELECTOR, "#layers .layer")[-1].get_attribute("data-layer")

    def toggle(which: str) -> None:  # the list is drawn anew on each change: found each time
        def clicked() -> bool:
            try:
                browser.find_element(
                    By.CSS_SELECTOR, f'#layers .layer[data-layer="{name}"] .layer-{which}'
                ).click()
            except StaleElementReferenceException:
                return False  # drawn anew between finding and clicking (a CI run): not clicked, again
            return True

        wait_for(browser, clicked, f"the layer's {which} toggle clicked")

    browser.find_element(By.ID, "zoom-fit").click()  # the whole sheet: an earlier test may have zoomed in
    reads: list = []
    ink = wait_for(browser, lambda: steady_ink(browser, "a > 0 && r < 80", reads), "the sheet drawn whole")
    toggle("show")
    wait_for(browser, lambda: sheet_pixels(browser, "a > 0 && r < 80") < ink, "the hidden layer's ink gone")
    toggle("plot")
    wait_for(browser, lambda: name in server.studio.placement.skip, "the skip reaches the server")
    assert name not in [layer.name for layer in server.studio.full_plan().layers]
    assert name in [layer.name for layer in server.studio.raw_plan().layers]
    toggle("plot")
    toggle("show")
    wait_for(browser, lambda: not server.studio.placement.skip, "plotted again")
    assert text(browser, "plan-error") == ""


pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")
