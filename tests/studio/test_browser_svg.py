"""Anyone's SVG drawing beside photos, in a real headless Chromium: read by the library's SVG
reader, fitted onto the sheet, reordered by the library's optimizer, shown, downloaded and
plotted; a file that is no drawing is refused in plain words."""

from __future__ import annotations

from pathlib import Path

import pytest
from selenium.webdriver.common.by import By
from studio_helpers import full_generation, sheet_pixels, text, wait_for

#: A drawing as Inkscape or a person writes one: mm size, a group, curves, shapes, out of order.
DRAWING = """<?xml version="1.0" encoding="UTF-8"?>
<svg xmlns="http://www.w3.org/2000/svg" width="120mm" height="80mm" viewBox="0 0 120 80">
  <g id="lines" style="fill:none;stroke:#000;stroke-width:0.4">
    <path d="M 100 10 L 110 70"/>
    <circle cx="30" cy="40" r="20"/>
    <path d="M 5 5 C 40 0, 80 80, 115 75"/>
    <rect x="60" y="20" width="30" height="30"/>
    <path d="M 10 70 L 20 60 L 30 70"/>
  </g>
</svg>
"""


@pytest.fixture(scope="module")
def drawing(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("svg") / "someones-drawing.svg"
    path.write_text(DRAWING, encoding="utf-8")
    return path


def library_plan(path: Path):
    """What the library makes of the drawing on the studio's default sheet."""
    from pencilbot import api
    from pencilbot.planning.layout import fit_plan
    from pencilbot.planning.optimize import reorder_plan
    from pencilbot.planning.style import default_style, load_style
    from pencilbot.units import CSS_PX_PER_INCH

    style = load_style(default_style())
    fitted = fit_plan(api.read_svg(path, dpi=CSS_PX_PER_INCH), style.page, style.orientation, style.margin)
    return reorder_plan(fitted).plan


def test_an_svg_drawing_is_read_optimised_shown_and_plottable(server, browser, drawing):
    from studio_helpers import same_plan

    browser.get(server.url)
    wait_for(browser, lambda: text(browser, "connection") == "connected", "the page connects")
    browser.find_element(By.ID, "photo-input").send_keys(str(drawing))
    wait_for(browser, lambda: full_generation(browser), "the drawing's full plan")
    assert "someones-drawing.svg: an SVG drawing of 120 × 80 mm" in text(browser, "photo-name")
    assert text(browser, "photo-error") == ""
    plan = server.studio.full_plan()
    assert same_plan(plan, library_plan(drawing))  # the library's reader and optimizer, as is
    assert (plan.page.width, plan.page.height) == (297, 210)  # the wide drawing on a turned A4
    assert text(browser, "fig-likeness").startswith("–")  # no photo to be like
    wait_for(browser, lambda: browser.execute_script("return !!sheet.plan"), "its paths on the sheet")
    assert sheet_pixels(browser, "a > 0 && r < 80 && g < 80 && b < 80") > 500
    assert browser.find_element(By.ID, "plot-start").is_enabled()
    assert not browser.find_element(By.ID, "dl-sketch").is_displayed()  # no sketch of a drawing


def test_a_file_that_is_no_drawing_is_refused_in_plain_words(server, browser, tmp_path):
    if not full_generation(browser):
        browser.get(server.url)
    bad = tmp_path / "broken.svg"
    bad.write_text("<svg xmlns='http://www.w3.org/2000/svg'><g>", encoding="utf-8")
    browser.find_element(By.ID, "photo-input").send_keys(str(bad))
    wait_for(browser, lambda: text(browser, "photo-error"), "the refusal")
    said = text(browser, "photo-error")
    assert said.startswith("broken.svg was not used: that SVG cannot be drawn") and "Traceback" not in said


pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")
