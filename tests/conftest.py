"""Every test runs without the user's own pencilbot configuration (their profiles, styles and
default profile), in an empty configuration folder of its own. This folder is on the import path
(pytest puts a conftest's folder there), so tests share the drawings of ``drawings.py``."""

import pytest


@pytest.fixture(autouse=True)
def own_config_folder(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("PENCILBOT_CONFIG_DIR", str(tmp_path_factory.mktemp("config")))
    monkeypatch.delenv("PENCILBOT_PROFILE", raising=False)
