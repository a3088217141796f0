"""The page by keyboard and in the dark, in a real headless Chromium: the system's dark colours
and a toggle, the shortcuts listed in a "?" panel, the photo picker reached by keys, the full
preview's planning steps shown as they happen, and a link from another page refused with a page
a person can read."""

from __future__ import annotations

import pytest
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from studio_helpers import full_generation, text, wait_for


def open_page(server, browser) -> None:
    browser.get(server.url)
    wait_for(browser, lambda: text(browser, "connection") == "connected", "the page connects")


def background(browser, selector: str = "html") -> list[int]:
    colour = browser.execute_script(
        "return getComputedStyle(document.querySelector(arguments[0])).backgroundColor", selector
    )
    return [int(part) for part in colour[colour.index("(") + 1 : colour.index(")")].split(",")[:3]]


def test_dark_colours_follow_the_system_and_the_toggle(server, browser):
    browser.execute_cdp_cmd(
        "Emulation.setEmulatedMedia", {"features": [{"name": "prefers-color-scheme", "value": "dark"}]}
    )
    try:
        open_page(server, browser)
        browser.execute_script("localStorage.removeItem('pencilbot-theme')")
        open_page(server, browser)
        assert sum(background(browser)) < 150  # the system says dark: the page is dark
        browser.find_element(By.ID, "theme").click()  # auto → dark
        browser.find_element(By.ID, "theme").click()  # dark → light
        assert text(browser, "theme-name") == "light" and sum(background(browser)) > 600
        open_page(server, browser)  # kept across a reload
        assert text(browser, "theme-name") == "light" and sum(background(browser)) > 600
        browser.find_element(By.TAG_NAME, "body").send_keys("d")
        assert text(browser, "theme-name") == "auto" and sum(background(browser)) < 150
    finally:
        browser.execute_cdp_cmd("Emulation.setEmulatedMedia", {"features": []})
        browser.execute_script("localStorage.removeItem('pencilbot-theme')")


def test_question_mark_lists_the_shortcuts(server, browser):
    open_page(server, browser)
    panel = browser.find_element(By.ID, "keys")
    assert not panel.is_displayed()
    browser.find_element(By.TAG_NAME, "body").send_keys("?")
    wait_for(browser, lambda: panel.is_displayed(), "the shortcuts panel")
    listed = panel.text
    for words in ("pick a photo", "undo", "redo", "zoom", "pen scale", "plot", "this list"):
        assert words in listed
    ActionChains(browser).send_keys(Keys.ESCAPE).perform()
    wait_for(browser, lambda: not panel.is_displayed(), "closed by Esc")


def test_the_photo_picker_is_reached_by_the_keyboard(server, browser):
    open_page(server, browser)
    browser.execute_script(  # a file chooser cannot open headless: count the picker's openings
        "window.picked = 0; document.getElementById('photo-input').addEventListener('click',"
        " (e) => { window.picked++; e.preventDefault(); });"
    )
    browser.execute_script("document.activeElement.blur()")  # from the top of the page
    for _ in range(8):  # Tab from the top of the page reaches the drop zone
        ActionChains(browser).send_keys(Keys.TAB).perform()
        if browser.execute_script("return document.activeElement.id") == "drop":
            break
    assert browser.execute_script("return document.activeElement.id") == "drop"
    ActionChains(browser).send_keys(Keys.ENTER).perform()
    assert browser.execute_script("return window.picked") == 1
    browser.execute_script("document.activeElement.blur()")
    ActionChains(browser).send_keys("o").perform()
    assert browser.execute_script("return window.picked") == 2


def test_the_full_preview_shows_its_planning_steps(server, browser, photo):
    open_page(server, browser)
    browser.execute_script(
        "window.steps = []; new MutationObserver(() => window.steps.push(document.getElementById('plan-step').textContent))"
        ".observe(document.getElementById('plan-step'), {childList: true, characterData: true, subtree: true});"
    )
    before = full_generation(browser)
    browser.find_element(By.ID, "photo-input").send_keys(str(photo))
    wait_for(browser, lambda: full_generation(browser) > before, "the full preview")
    steps = browser.execute_script("return window.steps")
    assert any(step.startswith("full preview: ") and "step " in step for step in steps), steps
    assert not browser.find_element(By.ID, "plan-progress").is_displayed()  # done: the bar goes


def test_a_link_from_another_page_gets_a_page_that_says_why(server, browser):
    browser.get(f"data:text/html,<a id=go href='{server.url}'>the studio</a>")
    browser.find_element(By.ID, "go").click()
    wait_for(browser, lambda: "pencilbot studio" in browser.title, "the refusal page")
    heading = browser.find_element(By.TAG_NAME, "h1").text
    assert heading == "This page can only be opened from pencilbot studio itself"
    assert "open the address that pencilbot studio printed" in browser.find_element(By.TAG_NAME, "body").text
    assert not browser.find_elements(By.ID, "sheet")  # still refused: no studio page


def test_the_refusal_is_html_for_a_person_and_plain_for_a_program(client):
    page = client.get("/", headers={"Sec-Fetch-Site": "cross-site", "Accept": "text/html,*/*"})
    assert page.status_code == 403 and page.headers["content-type"].startswith("text/html")
    assert "cross-site request refused" in page.text and "<script" not in page.text
    plain = client.post("/api/plot", headers={"Sec-Fetch-Site": "cross-site", "Accept": "text/html"})
    assert plain.status_code == 403 and plain.headers["content-type"].startswith("text/plain")


pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")
