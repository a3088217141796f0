"""Every test runs without the user's own pencilbot configuration (their profiles, styles and
default profile), in an empty configuration folder of its own. This folder is on the import path
(pytest puts a conftest's folder there), so tests share the drawings of ``drawings.py``."""

import logging
import os
import signal

import pytest


def pytest_configure(config):
    """The tests deliver stop signals to this process (a virtual board's ``interrupt@`` fault)
    and expect them to be heard as at a terminal. A shell's background job (``pytest &`` from a
    script, ``trap '' INT``) starts with SIGINT ignored, ``nohup`` with SIGHUP ignored, and the
    driver leaves an ignored signal ignored: the suite puts the usual handlers back (Python's
    own for Ctrl-C) so that it runs the same however it was started."""
    from pencilbot.driver.stop_signals import STOP_SIGNALS

    for signum in STOP_SIGNALS:
        if signal.getsignal(signum) is signal.SIG_IGN:
            signal.signal(signum, signal.default_int_handler if signum == signal.SIGINT else signal.SIG_DFL)


@pytest.fixture(autouse=True)
def own_log_levels():
    """``main([..., "-v"])`` sets pencilbot's loggers to DEBUG for the rest of the process: a later
    test's records (a file name that is not UTF-8 among them) would be captured into its report,
    which pytest-xdist cannot send. Each test starts from the levels the suite started with."""
    names = ("pencilbot", "sim", "firmware_protocol")
    levels = {name: logging.getLogger(name).level for name in names}
    yield
    for name, level in levels.items():
        logging.getLogger(name).setLevel(level)


@pytest.fixture(scope="session")
def own_cache_folder(tmp_path_factory):
    """The session's cache folder (a separation table solved once, not once per test)."""
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(autouse=True)
def own_config_folder(tmp_path_factory, monkeypatch, own_cache_folder):
    monkeypatch.setenv("PENCILBOT_CONFIG_DIR", str(tmp_path_factory.mktemp("config")))
    monkeypatch.setenv("PENCILBOT_CACHE_DIR", str(own_cache_folder))
    monkeypatch.delenv("PENCILBOT_PROFILE", raising=False)


#: Workers for the whole suite (``pytest -q``, pyproject's ``-n auto``). The suite mostly waits
#: (pseudo-terminals, virtual plotters on a real-time clock, a headless browser, CLI subprocesses),
#: so four workers overlap those waits even on a 2-core machine.
SUITE_WORKERS = 4


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_auto_num_workers(config):
    """How many pytest-xdist workers ``-n auto`` starts: :data:`SUITE_WORKERS` for the whole suite,
    none (the tests run in this process) when files or tests are named, where starting workers
    would cost more than it saves. ``-n N`` on the command line or $PYTEST_XDIST_AUTO_NUM_WORKERS
    still decide."""
    if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
        return None  # xdist's own reading of it
    return SUITE_WORKERS if config.args_source == pytest.Config.ArgsSource.TESTPATHS else 0
