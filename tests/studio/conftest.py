"""A real studio server (uvicorn on 127.0.0.1, a free port) and a real headless Chromium driven
by Selenium. Without the browser (Debian's ``chromium`` and ``chromium-driver``) the browser
tests fail: they are not skipped."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from studio_helpers import serving

CHROMIUM = ("/usr/bin/chromium", "/usr/bin/chromedriver")
#: The virtual plotter's speed over real time in the browser tests: slow enough to pause a plot
#: in the middle, quick enough to see it move.
SIM_SPEED = 8.0


@pytest.fixture(scope="module")
def photo(tmp_path_factory) -> Path:
    """skimage's coffee at half size: a real photo that plans in about a second."""
    from PIL import Image
    from skimage import data

    path = tmp_path_factory.mktemp("photo") / "coffee.png"
    Image.fromarray(data.coffee()).resize((300, 200), Image.LANCZOS).save(path)
    return path


@pytest.fixture(scope="module")
def config_dir(tmp_path_factory):
    """The module's server and the CLI runs it is compared with see no user configuration."""
    with pytest.MonkeyPatch.context() as patch:
        folder = tmp_path_factory.mktemp("config")
        patch.setenv("PENCILBOT_CONFIG_DIR", str(folder))
        patch.delenv("PENCILBOT_PROFILE", raising=False)
        yield folder


@pytest.fixture
def studio():
    """A studio with no photo, no plot (closed after the test)."""
    from pencilbot.studio.state import Studio

    made = Studio()
    yield made
    made.close()


@pytest.fixture
def client(studio):
    """The studio's app behind its guard, as its own page reaches it; a server error is a 500
    answer (not raised), as a browser would get it."""
    from starlette.testclient import TestClient

    from pencilbot.studio.app import create_app

    app = create_app(studio, port=8765, names=("testserver",))
    return TestClient(app, base_url="http://testserver:8765", raise_server_exceptions=False)


@pytest.fixture(scope="module")
def server(config_dir):
    from pencilbot.studio.server import prepare

    running = prepare(None, listen_port=0, sim_speed=SIM_SPEED)
    thread = serving(running)
    yield running
    for session in running.studio.plotters.sessions.values():
        session.press("stop")
        if session.thread is not None:
            session.thread.join(timeout=20)
    running.stop()
    thread.join(timeout=10)


@pytest.fixture(scope="module")
def downloads(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("downloads")


@pytest.fixture(scope="module")
def browser(downloads):
    missing = [path for path in CHROMIUM if shutil.which(path) is None]
    if missing:
        pytest.fail(
            f"the browser tests need Debian's chromium and chromium-driver ({', '.join(missing)} "
            "missing): apt-get install -y chromium chromium-driver"
        )
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM[0]
    for argument in (
        "--headless=new",
        "--no-sandbox",
        "--disable-dev-shm-usage",
        "--window-size=1400,860",
        "--disable-gpu",
        "--no-first-run",
    ):
        options.add_argument(argument)
    options.add_experimental_option(
        "prefs", {"download.default_directory": str(downloads), "download.prompt_for_download": False}
    )
    driver = webdriver.Chrome(service=Service(CHROMIUM[1]), options=options)
    driver.execute_cdp_cmd("Page.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(downloads)})
    yield driver
    driver.quit()
