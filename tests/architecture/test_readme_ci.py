"""The README is a user's page, and its commands are the ones CI runs.

`.ci/run` runs the README's test command in a fresh virtual environment: the same Debian test
tools and the same steps after the install (the static checks, then the tests). The command
works as root, where there is no `sudo`, and for a person, who needs it. The README stays short
(≤ 250 lines: the rest lives in docs/) and every docs/ page it points to exists."""

import re
import shlex
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")
CI = (ROOT / ".ci" / "run").read_text(encoding="utf-8")


def readme_test_command() -> str:
    section = README.split("### Run the tests", 1)[1]
    return re.search(r"```sh\n(.*?)\n```", section, re.S)[1]


def steps(command: str) -> list[str]:
    """The command's steps, split at ``&&`` and ``;``."""
    return [step.strip() for step in re.split(r"&&|;", command) if step.strip()]


def apt_packages(text: str) -> list[str]:
    words = shlex.split(re.search(r"apt-get install -y (?:-q )?([^&>\n]*)", text)[1])
    return sorted(word for word in words if not word.startswith("-"))


def after_install(lines: list[str]) -> list[str]:
    """The steps from ``pip install ".[test]"`` on."""
    start = next(i for i, line in enumerate(lines) if line == 'pip install ".[test]"')
    return lines[start:]


def test_ci_installs_the_readme_test_tools():
    assert apt_packages(readme_test_command()) == apt_packages(CI)
    assert "chromium" in apt_packages(CI)


def test_ci_runs_the_readme_steps_after_the_install_in_order():
    ci_lines = [
        line.strip() for line in CI.splitlines() if line.strip() and not line.lstrip().startswith("#")
    ]
    readme = after_install(steps(readme_test_command()))
    assert readme == after_install(ci_lines)
    assert readme[-1] == "pytest -q"
    assert {"ruff check .", "mypy pencilbot firmware_protocol sim"} <= set(
        readme[:-1]
    )  # the static checks, before the tests


def test_the_test_command_needs_sudo_only_when_not_root():
    command = readme_test_command()
    assert not re.search(r"(^|[;&|]\s*)sudo\s", command)  # no bare sudo: root has none
    prefix = steps(command)[0]  # the guard choosing the prefix
    chosen = subprocess.run(
        ["bash", "-c", f'{prefix}; printf %s "$S"'], capture_output=True, text=True, check=True
    ).stdout
    assert chosen == (
        "" if subprocess.run(["id", "-u"], capture_output=True, text=True).stdout.strip() == "0" else "sudo"
    )


def test_the_readme_is_a_short_page():
    assert len(README.splitlines()) <= 250


@pytest.mark.parametrize("page", sorted(set(re.findall(r"\]\((docs/[^)#]+)", README))))
def test_every_page_the_readme_points_to_exists(page):
    assert (ROOT / page).is_file()
