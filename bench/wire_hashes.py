"""SHA-256 of what each plotter family's virtual board accepts when the driver draws one small
drawing on it, and of the exported program: a refactor of ``pencilbot/driver`` or ``sim`` that
must not change what a plotter is sent shows the same hashes before and after.

Profiles: grbl-servo-a4 and grbl-z-a3 (G-code streaming), axidraw-v3 (EBB host motion), hp7475a
(HP-GL polling). Each: ``pencilbot export`` of a few straight paths in a fresh process, then
``pencilbot.driver.draw`` to ``sim://``. Prints JSON: ``{profile: {"program", "accepted", "lines",
"seconds"}}`` (hash prefixes, the lines the board accepted, its simulated seconds).

Usage: ``PYTHONPATH=$PWD python bench/wire_hashes.py``
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import sim
from pencilbot.driver import draw
from sim import protocol_sim

SVG = """<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="80mm" viewBox="0 0 100 80">
<path d="M 10 10 L 90 10 L 90 70 L 10 70 Z" fill="none" stroke="black"/>
<path d="M 20 20 L 80 60 M 20 60 L 80 20" fill="none" stroke="black"/>
<polyline points="30,40 40,45 50,40 60,45 70,40" fill="none" stroke="black"/>
</svg>"""
PROFILES = {"grbl-servo-a4": "gcode", "grbl-z-a3": "gcode", "axidraw-v3": "gcode", "hp7475a": "hpgl"}


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:16]


def main() -> None:
    out = {}
    sim.register()
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        (folder / "d.svg").write_text(SVG)
        for profile, suffix in PROFILES.items():
            program = folder / f"{profile}.{suffix}"
            subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "pencilbot.cli",
                    "export",
                    "d.svg",
                    "-o",
                    program.name,
                    "--profile",
                    profile,
                ],
                check=True,
                cwd=folder,
                capture_output=True,
            )
            name = f"wire-{profile}"
            draw(str(program), f"sim://{name}?profile={profile}", profile=profile)
            board = protocol_sim.plotter(name)
            lines = board.firmware.accepted_lines()
            out[profile] = {
                "program": _sha(program.read_bytes()),
                "accepted": _sha("\n".join(lines).encode()),
                "lines": len(lines),
                "seconds": round(board.seconds, 6),
            }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
