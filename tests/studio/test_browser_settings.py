"""The studio page shows what will be drawn, in every tab: an empty page shows no broken
pictures nor dead links, a style's own settings apply until the person moves a control, a
second tab shows the same settings, and a file that is not a photo is refused in plain words
while the photo in use stays (and says so)."""

from __future__ import annotations

import pytest
from selenium.common.exceptions import TimeoutException
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select
from studio_helpers import full_generation, load_photo, screenshot, set_control, text, wait_for

from pencilbot import api


def test_an_empty_page_shows_no_broken_picture_and_no_dead_link(server, browser):
    browser.get(server.url)
    wait_for(browser, lambda: text(browser, "connection") == "connected", "the page connects")
    for image in ("preview", "sketch", "photo"):
        assert not browser.find_element(By.ID, image).is_displayed(), f"an empty {image} box"
    assert not browser.find_element(By.ID, "dl-svg").is_displayed()
    assert text(browser, "preview-stage") == "no photo yet"
    screenshot(browser, "0-empty")


def test_the_outline_style_does_not_hatch_unless_asked(server, browser, photo):
    before = load_photo(server, browser, photo)
    assert browser.find_element(By.ID, "hatch").is_selected()  # the default style hatches
    Select(browser.find_element(By.ID, "style")).select_by_value("outline")
    wait_for(browser, lambda: full_generation(browser) > before, "the outline plan")
    assert not browser.find_element(By.ID, "hatch").is_selected()
    assert server.studio.options.hatch is None and not server.studio.options.resolved_style().hatch
    paths = int(text(browser, "fig-paths").split()[0])
    assert paths == sum(
        len(layer.paths) for layer in api.plan(photo, style="outline").layers
    )  # the CLI's plan

    outline = full_generation(browser)
    browser.find_element(By.ID, "hatch").click()  # asked for: it hatches, whatever the style
    wait_for(browser, lambda: full_generation(browser) > outline, "the hatched outline plan")
    assert server.studio.options.hatch is True and int(text(browser, "fig-paths").split()[0]) > paths
    Select(browser.find_element(By.ID, "style")).select_by_value("sketchy")
    wait_for(browser, lambda: server.studio.options.style == "sketchy", "the sketchy style")
    assert browser.find_element(By.ID, "hatch").is_selected() and server.studio.options.hatch is True


def test_the_face_lines_box_asks_for_the_faces_lines_and_unticked_gives_the_style_back(
    server, browser, photo
):
    if not full_generation(browser):
        load_photo(server, browser, photo)
    Select(browser.find_element(By.ID, "style")).select_by_value("default")
    wait_for(browser, lambda: server.studio.options.style == "default", "the default style")
    box = browser.find_element(By.ID, "face_lines")
    assert not box.is_selected()  # the default style draws faces in runs only
    before = full_generation(browser)
    box.click()
    wait_for(browser, lambda: server.studio.options.face_lines is True, "face lines reach the server")
    assert server.studio.options.resolved_style().face_lines
    wait_for(browser, lambda: full_generation(browser) > before, "the plan drawn again")
    box.click()  # unticked: asked for no lines, as the style says
    wait_for(browser, lambda: server.studio.options.face_lines is False, "no face lines")
    assert not server.studio.options.resolved_style().face_lines


def test_the_plot_time_control_asks_for_a_longer_plot(server, browser, photo):
    if not full_generation(browser):
        load_photo(server, browser, photo)
    Select(browser.find_element(By.ID, "style")).select_by_value("default")
    wait_for(browser, lambda: server.studio.options.style == "default", "the default style")
    assert float(browser.find_element(By.ID, "time_budget").get_attribute("value")) == 1.0  # the style's
    before = full_generation(browser)
    set_control(browser, "time_budget", 2.5)
    wait_for(browser, lambda: server.studio.options.time_budget == 2.5, "the plot time reaches the server")
    assert server.studio.options.resolved_style().time_budget == 2.5
    wait_for(browser, lambda: full_generation(browser) > before, "the plan drawn again")
    assert browser.find_element(By.CSS_SELECTOR, 'output[for="time_budget"]').text == "2.5"


def test_a_second_tab_shows_the_same_settings_as_the_first(server, browser, photo):
    if not full_generation(browser):
        load_photo(server, browser, photo)
    first = browser.current_window_handle
    browser.switch_to.new_window("tab")
    second = browser.current_window_handle
    try:
        browser.get(server.url)
        wait_for(browser, lambda: full_generation(browser), "the second tab shows the plan")
        before = full_generation(browser)
        Select(browser.find_element(By.ID, "style")).select_by_value("outline")
        set_control(browser, "pen_width", 0.9)
        wait_for(
            browser,
            lambda: full_generation(browser) > before and server.studio.options.pen_width == 0.9,
            "the second tab's plan",
        )
        newest = server.studio.planner.generation
        browser.switch_to.window(first)
        wait_for(browser, lambda: full_generation(browser) == newest, "the first tab shows the newest plan")
        assert (
            Select(browser.find_element(By.ID, "style")).first_selected_option.get_attribute("value")
            == "outline"
        )
        assert browser.find_element(By.ID, "pen_width").get_attribute("value") == "0.9"
        assert browser.find_element(By.CSS_SELECTOR, "output[for=pen_width]").text == "0.9"
        assert (
            browser.find_element(By.ID, "hatch").is_selected() == server.studio.options.resolved_style().hatch
        )
    finally:
        browser.switch_to.window(second)
        browser.close()
        browser.switch_to.window(first)


def test_a_bad_file_over_a_photo_is_refused_in_plain_words_and_the_photo_stays(
    server, browser, photo, tmp_path
):
    if not full_generation(browser):
        load_photo(server, browser, photo)
    generation = server.studio.planner.generation
    bad = tmp_path / "holiday.png"
    bad.write_text("these are my notes, not a photo")
    browser.find_element(By.ID, "photo-input").send_keys(str(bad))
    said = wait_for(browser, lambda: text(browser, "photo-error"), "a message about the file")
    assert said.startswith("holiday.png was not used: that file is not an image")
    assert "The drawing still uses coffee.png." in said
    assert "coffee.png: 300 × 200 px" in text(browser, "photo-name")
    assert "kept" in browser.find_element(By.ID, "photo-name").get_attribute("class")
    assert server.studio.planner.generation == generation, "the old photo was planned again"
    assert server.studio.photo_info["name"] == "coffee.png"
    screenshot(browser, "7-bad-file")


pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


def test_the_phone_page_is_no_wider_than_the_phone_with_a_long_port_name(server, browser, photo):
    long_port = "/dev/serial/by-id/usb-1a86_USB2.0-Serial_A50285BI12345678-if00-port0"
    server.studio.ports = (long_port,)
    size = browser.get_window_size()
    browser.set_window_size(390, 844)
    try:
        width = browser.execute_script("return window.innerWidth")
        load_photo(server, browser, photo)
        Select(browser.find_element(By.ID, "port")).select_by_value(long_port)
        wide = browser.execute_script(
            "return [document.documentElement.scrollWidth, ...[...document.querySelectorAll('main *')]"
            ".filter((e) => e.getBoundingClientRect().right > window.innerWidth + 0.5).map((e) => e.id || e.tagName)]"
        )
        assert wide[0] <= width and wide[1:] == [], wide
        screenshot(browser, "8-phone")
    finally:
        server.studio.ports = ()
        browser.set_window_size(size["width"], size["height"])


def test_the_status_says_plotting_in_plain_words(server, browser):
    browser.get(server.url)
    wait_for(browser, lambda: text(browser, "connection") == "connected", "the page connects")
    said = browser.execute_script("return ['Idle', 'Run', 'Hold:0', '', 'Alarm'].map(plotting)")
    assert said == ["plotting", "plotting", "plotting (holding)", "starting", "plotting (alarm)"]


def test_the_machine_controls_move_the_virtual_plotter(server, browser):
    from sim import protocol_sim

    browser.get(server.url)
    wait_for(browser, lambda: text(browser, "connection") == "connected", "the page connects")
    Select(browser.find_element(By.ID, "port")).select_by_value("sim://")
    board = f"studio-{Select(browser.find_element(By.ID, 'profile')).first_selected_option.get_attribute('value')}"
    protocol_sim.forget(
        board
    )  # a board another test in this worker left (motors off, a plot's state) is not this one

    def press(button: str, expect: str) -> str:
        browser.find_element(By.ID, button).click()
        try:
            return wait_for(
                browser,
                lambda: expect in text(browser, "plot-message") and text(browser, "plot-message"),
                f"the answer to {button}",
            )
        except TimeoutException:  # say what the page said instead
            raise AssertionError(
                f"{button}: the page said {text(browser, 'plot-message')!r}, "
                f"{text(browser, 'plan-error')!r}; expected {expect!r}"
            ) from None

    press("pen-down", "the pen is down")
    assert protocol_sim.plotter(board).machine.pen_down
    browser.execute_script("showPlot()")  # a state update (as every event brings) keeps the answer
    assert "the pen is down" in text(browser, "plot-message")
    press("pen-toggle", "the pen is up")
    assert not protocol_sim.plotter(board).machine.pen_down
    Select(browser.find_element(By.ID, "walk-step")).select_by_value("10")
    walked = press("walk-right", "walked: the carriage is at")
    x, y = (float(v) for v in walked.split(" at ")[1].removesuffix(" mm").split(", "))
    press("walk-up", f"walked: the carriage is at {x:.1f}, {y + 10:.1f} mm")
    press("home", "home")
    assert "motors off" in press("motors-off", "motors off")
    screenshot(browser, "9-machine")
