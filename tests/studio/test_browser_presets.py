"""Presets and undo in a real headless Chromium: settings saved by name in the user's config
folder, loaded, deleted, reset to the style's own; undo and redo by buttons and by keys."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from selenium.webdriver.support.ui import Select
from studio_helpers import set_control, text, wait_for


def open_page(server, browser) -> None:
    browser.get(server.url)
    wait_for(browser, lambda: text(browser, "connection") == "connected", "the page connects")


def pick(browser, element_id: str, value: str) -> None:
    Select(browser.find_element(By.ID, element_id)).select_by_value(value)


def test_a_preset_is_saved_in_the_config_folder_loaded_and_deleted(server, browser):
    config_dir = Path(os.environ["PENCILBOT_CONFIG_DIR"])  # this test's own (tests/conftest.py)
    open_page(server, browser)
    pick(browser, "style", "outline")
    set_control(browser, "place-scale", 80)
    wait_for(browser, lambda: server.studio.placement.scale == 0.8, "the placement")
    browser.find_element(By.ID, "preset-name").send_keys("thin outline")
    browser.find_element(By.ID, "preset-save").click()
    saved = config_dir / "studio-presets" / "thin outline.json"
    wait_for(browser, lambda: text(browser, "preset-message"), "the preset saved")
    assert text(browser, "preset-message") == "saved as thin outline" and saved.is_file()
    kept = json.loads(saved.read_text())
    assert kept["options"]["style"] == "outline" and kept["placement"]["scale"] == 0.8

    browser.find_element(By.ID, "reset").click()  # the defaults: the default style, centred, full size
    wait_for(browser, lambda: server.studio.options.style in ("", None), "reset reaches the server")
    wait_for(browser, lambda: server.studio.placement.scale == 1, "the placement reset")
    assert (
        Select(browser.find_element(By.ID, "style")).first_selected_option.get_attribute("value") != "outline"
    )

    open_page(server, browser)  # a page opened later lists it
    wait_for(browser, lambda: len(Select(browser.find_element(By.ID, "preset-list")).options) > 1, "the list")
    pick(browser, "preset-list", "thin outline")
    browser.find_element(By.ID, "preset-load").click()
    wait_for(browser, lambda: server.studio.options.style == "outline", "the preset's style")
    wait_for(browser, lambda: server.studio.placement.scale == 0.8, "the preset's placement")
    assert browser.find_element(By.ID, "place-scale").get_attribute("value") == "80"

    browser.find_element(By.ID, "preset-delete").click()
    wait_for(browser, lambda: not saved.exists(), "the file removed")
    browser.find_element(By.ID, "preset-name").clear()
    browser.find_element(By.ID, "preset-name").send_keys("../escape")
    browser.find_element(By.ID, "preset-save").click()
    wait_for(browser, lambda: "a preset name is up to 40" in text(browser, "preset-message"), "the refusal")
    assert not (config_dir / "escape.json").exists()


def test_undo_and_redo_by_buttons_and_keys(server, browser):
    open_page(server, browser)
    browser.find_element(By.ID, "reset").click()
    # The reset done (its settings at the server and its undo step taken), as a person sees it:
    # the placement alone may already be the default, and a pick made meanwhile raced its requests.
    wait_for(browser, lambda: "the style's own settings" in text(browser, "preset-message"), "a clean start")
    wait_for(browser, lambda: server.studio.placement.scale == 1, "a clean start at the server")
    pick(browser, "style", "outline")
    wait_for(browser, lambda: server.studio.options.style == "outline", "outline")
    pick(browser, "pens", "cmyk")
    wait_for(browser, lambda: server.studio.options.pens == "cmyk", "cmyk")

    browser.find_element(By.ID, "undo").click()
    wait_for(browser, lambda: server.studio.options.pens in ("", None), "the pen set undone")
    assert server.studio.options.style == "outline"
    browser.find_element(By.ID, "redo").click()
    wait_for(browser, lambda: server.studio.options.pens == "cmyk", "redone")

    browser.execute_script("document.activeElement.blur()")  # keys to the page, not a field
    ActionChains(browser).key_down(Keys.CONTROL).send_keys("z").key_up(Keys.CONTROL).perform()
    wait_for(browser, lambda: server.studio.options.pens in ("", None), "Ctrl-Z")
    ActionChains(browser).key_down(Keys.CONTROL).send_keys("z").key_up(Keys.CONTROL).perform()
    wait_for(browser, lambda: server.studio.options.style != "outline", "Ctrl-Z again")
    ActionChains(browser).key_down(Keys.CONTROL).key_down(Keys.SHIFT).send_keys("z").key_up(
        Keys.SHIFT
    ).key_up(Keys.CONTROL).perform()
    wait_for(browser, lambda: server.studio.options.style == "outline", "Ctrl-Shift-Z")
    assert (
        Select(browser.find_element(By.ID, "style")).first_selected_option.get_attribute("value") == "outline"
    )


pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")
