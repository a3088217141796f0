"""Write docs/demo-summary.md: what ``pencilbot demo`` prints on a fresh install, word for word.

Runs ``pencilbot demo -o DIR`` (scikit-image's coffee photo, the default style, page and
profile) in a temporary folder and keeps the summary it prints after its progress lines, so the
figures the README points to are the ones a new user sees, not ones copied by hand.
Usage: ``python docs/demo_summary.py``.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent


def demo_output() -> str:
    with tempfile.TemporaryDirectory() as tmp:
        done = subprocess.run(
            [sys.executable, "-m", "pencilbot.cli", "demo", "-o", "demo-out"],
            cwd=tmp,
            check=True,
            capture_output=True,
            text=True,
        )
    return done.stdout


def summary_lines(output: str) -> list[str]:
    """The demo's closing summary: the lines after its progress (which start with two spaces)."""
    lines = output.rstrip("\n").splitlines()
    last_progress = max((i for i, line in enumerate(lines) if line.startswith("  ")), default=0)
    return [line for line in lines[last_progress + 1 :] if line.strip()]


def main() -> None:
    summary = summary_lines(demo_output())
    if not summary:
        raise SystemExit("pencilbot demo printed no summary")
    page = HERE / "demo-summary.md"
    page.write_text(
        "# What the demo prints\n\n"
        "`pencilbot demo -o demo-out` on a fresh install: scikit-image's coffee photo in the default style\n"
        "on A4, turned landscape to suit the photo, 0.5 mm pen, `grbl-servo-a4`.\n"
        "Written by `python docs/demo_summary.py`; run it again after a change that moves these figures.\n\n```\n"
        + "\n".join(summary)
        + "\n```\n"
    )
    print(f"wrote {page}")


if __name__ == "__main__":
    main()
