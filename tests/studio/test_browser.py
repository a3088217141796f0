"""The studio page in a real headless Chromium: make a drawing, download it, plot it on the
virtual plotter, pause, resume, answer a pen change, stop. Screenshots of each step go to
docs/images/studio-*.png."""

from __future__ import annotations

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select
from studio_helpers import (
    full_generation,
    load_photo,
    same_plan,
    screenshot,
    set_control,
    sheet_pixels,
    text,
    wait_for,
)


def test_load_a_photo_move_a_control_see_preview_and_figures_change(server, browser, photo):
    first = load_photo(server, browser, photo)
    assert "300 × 200 px" in text(browser, "photo-name")
    figures = {name: text(browser, f"fig-{name}") for name in ("pen-down", "lifts", "time", "likeness")}
    assert figures["pen-down"].endswith(" m") and figures["likeness"].startswith("ρ ")
    preview = browser.find_element(By.ID, "preview").get_attribute("src")
    assert browser.execute_script("return document.getElementById('preview').naturalWidth") > 100
    screenshot(browser, "1-photo")

    set_control(browser, "pen_width", 1.2)
    assert (
        text(browser, "pen_width") == ""
        and browser.find_element(By.CSS_SELECTOR, "output[for=pen_width]").text == "1.2"
    )
    second = wait_for(
        browser, lambda: full_generation(browser) > first and full_generation(browser), "a new full preview"
    )
    assert browser.find_element(By.ID, "preview").get_attribute("src") != preview
    changed = {name: text(browser, f"fig-{name}") for name in figures}
    assert changed["pen-down"] != figures["pen-down"]  # a wider pen hatches fewer lines
    assert server.studio.options.pen_width == 1.2 and second > first
    screenshot(browser, "2-wider-pen")


def test_the_downloaded_svg_is_pencilbot_plan_of_the_same_options(
    server, browser, photo, downloads, tmp_path
):
    from pencilbot.cli import main
    from pencilbot.export.svg_read import read_svg

    if not full_generation(browser):
        load_photo(server, browser, photo)
    before = full_generation(browser)
    Select(browser.find_element(By.ID, "page")).select_by_value("A5")
    set_control(browser, "pen_width", 0.8)
    wait_for(browser, lambda: full_generation(browser) > before, "the A5 plan")
    for old in downloads.glob("plan*.svg"):
        old.unlink()
    browser.find_element(By.ID, "dl-svg").click()
    got = wait_for(browser, lambda: next(iter(downloads.glob("plan*.svg")), None), "the SVG download")
    wait_for(
        browser,
        lambda: got.stat().st_size > 0 and not list(downloads.glob("*.crdownload")),
        "the download ends",
    )

    expected = tmp_path / "cli.svg"
    assert main(["plan", str(photo), "-o", str(expected), "--page", "A5", "--pen-width", "0.8", "-q"]) == 0
    ours, theirs = read_svg(got), read_svg(expected)
    assert sum(len(layer.paths) for layer in ours.layers) > 100
    assert same_plan(ours, theirs)
    assert (ours.page.width, ours.page.height) == (210.0, 148.0)  # auto: the landscape photo turns A5


def plot_record(server) -> dict:
    plot = server.studio.plotters.sessions.get("sim://")
    return (
        {}
        if plot is None
        else {**plot.record, "status": plot.status, "active": plot.active, "prompt": plot.prompt}
    )


def test_plot_on_the_virtual_plotter_pause_resume_reopen_stop(server, browser, photo):
    if not full_generation(browser):
        load_photo(server, browser, photo)
    Select(browser.find_element(By.ID, "port")).select_by_value("sim://")
    browser.find_element(By.ID, "plot-start").click()
    wait_for(browser, lambda: (plot_record(server).get("running") or 0) > 20, "the machine draws")
    wait_for(browser, lambda: text(browser, "plot-status").startswith("plotting"), "the page says so")
    line = text(browser, "plot-line")
    assert " acknowledged)" in line and text(browser, "plot-remaining") != "–"
    drawn = wait_for(  # black ink on the sheet: what the machine has drawn, in its pen's colour
        browser,
        lambda: sheet_pixels(browser, "a > 0 && r < 60 && g < 60 && b < 60"),
        "the sheet shows the drawn lines",
    )
    assert drawn > 0
    screenshot(browser, "3-plotting")

    browser.find_element(By.ID, "pause").click()
    wait_for(browser, lambda: text(browser, "plot-status").startswith("paused"), "paused")
    wait_for(browser, lambda: text(browser, "pause") == "Resume", "the button offers to resume")
    held = plot_record(server)
    threading_wait(1.0)
    assert plot_record(server).get("running") == held.get("running")  # the machine stands
    screenshot(browser, "4-paused")
    browser.find_element(By.ID, "pause").click()
    wait_for(
        browser, lambda: (plot_record(server).get("running") or 0) > (held.get("running") or 0), "it draws on"
    )

    browser.get(server.url)  # the tab closed and opened again: the plot goes on, and shows
    wait_for(
        browser,
        lambda: text(browser, "plot-status").startswith("plotting"),
        "the reopened page shows the plot",
    )
    assert plot_record(server)["active"]

    browser.find_element(By.ID, "stop").click()
    wait_for(browser, lambda: text(browser, "plot-status") == "stopped", "stopped")
    message = text(browser, "plot-message")
    assert "stopped by the stop key" in message and "pen raised" in message
    assert 'Press "Resume the stopped plot"' in message and "pencilbot draw" not in message
    assert str(server.studio.folder) not in message and ".gcode" not in message
    assert browser.find_element(By.ID, "resume-job").is_displayed()
    screenshot(browser, "5-stopped")


def test_a_cmyk_job_asks_for_each_pen_in_a_dialog(server, browser, photo):
    if not full_generation(browser):
        load_photo(server, browser, photo)
    before = full_generation(browser)
    Select(browser.find_element(By.ID, "pens")).select_by_value("cmyk")
    wait_for(browser, lambda: full_generation(browser) > before, "the cmyk plan")
    Select(browser.find_element(By.ID, "port")).select_by_value("sim://")
    browser.find_element(By.ID, "plot-start").click()
    dialog = browser.find_element(By.ID, "prompt")
    wait_for(browser, lambda: dialog.is_displayed(), "the pen change dialog")
    first = text(browser, "prompt-text")
    assert "pen change: insert" in first
    screenshot(browser, "6-pen-change")
    paused_at = plot_record(server)["line"]
    browser.find_element(By.ID, "prompt-go").click()
    wait_for(
        browser,
        lambda: (
            plot_record(server)["line"] > paused_at + 10
            or (plot_record(server)["prompt"] or {}).get("text", first) != first
        ),
        "the plot goes on",
    )
    # the first pen's lines on the sheet, in its colour (not grey, not the red carriage dot)
    wait_for(
        browser,
        lambda: sheet_pixels(browser, INKED) > 100 or dialog.is_displayed(),
        "coloured lines on the sheet",
    )
    assert sheet_pixels(browser, INKED) > 100
    if dialog.is_displayed():
        browser.find_element(By.ID, "prompt-stop").click()
    else:
        browser.find_element(By.ID, "stop").click()
    wait_for(browser, lambda: plot_record(server)["status"] == "stopped", "stopped")
    assert "stopped by the stop" in text(browser, "plot-message") and "pen raised" in text(
        browser, "plot-message"
    )


INKED = "a > 0 && Math.max(r, g, b) - Math.min(r, g, b) > 50 && !(r > 200 && g < 90 && b < 90)"


def threading_wait(seconds: float) -> None:
    import threading

    threading.Event().wait(seconds)


pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")
