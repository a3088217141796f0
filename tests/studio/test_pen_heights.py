"""Pen heights from the page, for every firmware family the machine-control API serves: the
profile's values shown in its unit, a trial on the (virtual) plotter with the values given, and
both kept in the user's own copy of the profile; a plotter whose pen has no heights says so."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import Select
from studio_helpers import text, wait_for

from pencilbot.machine.profile import load_profile

HEADERS = {"X-Studio": "1"}
#: One profile of each family the virtual plotter speaks: GRBL servo and Z, grblHAL, the EBB boards
#: (Marlin goes through the same G-code control as GRBL; the virtual plotter does not speak it).
FAMILIES = ["grbl-servo-a4", "grbl-z-a3", "grblhal-servo-a3", "axidraw-v3", "nextdraw-8511"]


@pytest.mark.parametrize("name", FAMILIES)
def test_a_trial_and_saving_the_heights_for_each_family(client, name):
    profile = load_profile(name)
    shown = client.get("/api/pen-heights", params={"profile": name}).json()
    assert (shown["up"], shown["down"]) == (profile.pen.up, profile.pen.down) and shown["unit"]
    down = round(profile.pen.down * 0.9 + profile.pen.up * 0.1, 1)
    tried = client.post(
        "/api/pen-height/try",
        json={"port": "sim://", "profile": name, "which": "down", "value": down},
        headers=HEADERS,
    )
    assert tried.status_code == 200, tried.text
    assert tried.json()["said"].startswith(f"pen down at {down:g}")
    saved = client.post(
        "/api/pen-height/save",
        json={"port": "sim://", "profile": name, "up": profile.pen.up, "down": down},
        headers=HEADERS,
    )
    assert saved.status_code == 200, saved.text
    own = Path(os.environ["PENCILBOT_CONFIG_DIR"]) / "plotters" / f"{name}.toml"
    assert tomllib.loads(own.read_text())["pen"]["down"] == down
    assert load_profile(name).pen.down == down  # every later plot uses it


def test_a_plotter_without_heights_and_a_bad_height_are_refused_in_plain_words(client):
    hpgl = client.post(
        "/api/pen-height/try",
        json={"port": "sim://", "profile": "hp7475a", "which": "down", "value": 10},
        headers=HEADERS,
    )
    assert hpgl.status_code == 400 and "no heights to try" in hpgl.json()["error"]
    profile = load_profile("grbl-servo-a4")
    same = client.post(
        "/api/pen-height/save",
        json={"port": "sim://", "profile": "grbl-servo-a4", "up": profile.pen.up, "down": profile.pen.up},
        headers=HEADERS,
    )
    assert same.status_code == 400 and "Traceback" not in same.text
    assert not (Path(os.environ["PENCILBOT_CONFIG_DIR"]) / "plotters" / "grbl-servo-a4.toml").exists()


def test_the_page_tries_the_heights_in_its_fields_and_saves_them(server, browser):
    browser.get(server.url)
    wait_for(browser, lambda: text(browser, "connection") == "connected", "the page connects")
    Select(browser.find_element(By.ID, "port")).select_by_value("sim://")
    Select(browser.find_element(By.ID, "profile")).select_by_value("grbl-servo-a4")
    profile = load_profile("grbl-servo-a4")
    field = browser.find_element(By.ID, "height-down")
    wait_for(browser, lambda: field.get_attribute("value") == f"{profile.pen.down:g}", "the profile's height")
    field.clear()
    field.send_keys("80")
    browser.find_element(By.ID, "try-down").click()
    wait_for(browser, lambda: text(browser, "plot-message").startswith("pen down at 80"), "the trial")
    browser.find_element(By.ID, "heights-save").click()
    wait_for(browser, lambda: "kept in" in text(browser, "plot-message"), "saved")
    assert load_profile("grbl-servo-a4").pen.down == 80


pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")
