"""The shipped configs live in the repository's top-level configs/ and are found from the
installed package and from a source checkout run in place."""

import subprocess
import sys
from pathlib import Path

from pencilbot.configs_io import CONFIG_ROOTS, config_folder, shipped_names

CHECKOUT = Path(__file__).resolve().parents[2]


def test_every_file_in_the_top_level_configs_folder_is_shipped():
    for folder in ("plotters", "styles", "pens"):
        in_checkout = sorted(p.stem for p in (CHECKOUT / "configs" / folder).glob("*.toml"))
        assert in_checkout and shipped_names(folder) == in_checkout
        assert config_folder(folder).parent in CONFIG_ROOTS


def test_a_source_checkout_finds_the_configs_without_being_installed():
    # `python -m` from the checkout imports the checkout's pencilbot, whatever is installed.
    done = subprocess.run(
        [sys.executable, "-m", "pencilbot.cli", "export", "--list-profiles"],
        cwd=CHECKOUT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert [line.split()[0] for line in done.stdout.splitlines()] == shipped_names("plotters")
    done = subprocess.run(
        [sys.executable, "-c", "import pencilbot.configs_io as c; print(c.config_folder('styles'))"],
        cwd=CHECKOUT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert Path(done.stdout.strip()) == CHECKOUT / "configs" / "styles"
