"""SHA-256 of the bench photos' plans, SVG and G-code, as the CLI writes them: a refactor that
must not change what is drawn shows the same hashes before and after.

Photos: skimage's coffee, astronaut, camera, a 1 MP photo (astronaut upscaled to 1024×1024 as
``bench/plan.py`` makes it), coffee with ``--pens cmyk``, astronaut in the ``sketchy`` style, and
the coffee plan reordered by ``pencilbot optimize`` after its paths were reversed in the file.
Each runs through ``pencilbot plan`` and ``pencilbot export`` (the default profile) in a fresh
process. Prints JSON: ``{name: {"svg": sha256, "gcode": sha256}}``.

Usage: ``python bench/plan_hashes.py [--only NAME ...] [--keep DIR]``
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np
from skimage import data

# name: (image, extra options)
CASES = {
    "coffee": ("coffee", []),
    "astronaut": ("astronaut", []),
    "camera": ("camera", []),
    "photo_1mp": ("photo_1mp", []),
    "coffee_cmyk": ("coffee", ["--pens", "cmyk"]),
    "astronaut_sketchy": ("astronaut", ["--style", "sketchy"]),
}


def _image(name: str) -> np.ndarray:
    if name == "photo_1mp":
        return cv2.resize(data.astronaut(), (1024, 1024), interpolation=cv2.INTER_CUBIC)
    return getattr(data, name)()


def _write_photo(name: str, folder: Path) -> Path:
    path = folder / f"{name}.png"
    if not path.exists():
        rgb = _image(name)
        cv2.imwrite(str(path), rgb if rgb.ndim == 2 else cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    return path


def _pencilbot(folder: Path, *args: str) -> None:
    """Run the CLI in ``folder`` on file names relative to it (plans record their source's name)."""
    subprocess.run([sys.executable, "-m", "pencilbot.cli", *args], check=True, timeout=900, cwd=folder)


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _reversed_paths_svg(plan_svg: Path, out: Path) -> None:
    """The plan's SVG with every path's points in reverse order (another tool's drawing for optimize)."""
    text = plan_svg.read_text()

    def turn(match: re.Match) -> str:
        points = match.group(1).replace("M", " ").replace("L", " ").split()
        pairs = [points[i : i + 2] for i in range(0, len(points), 2)][::-1]
        coords = [" ".join(p) for p in pairs]
        return f'd="M {coords[0]} L {" ".join(coords[1:])}"'

    out.write_text(re.sub(r'd="(M[^"]*)"', turn, text))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", help="only these cases")
    parser.add_argument("--keep", type=Path, help="keep the files in this folder")
    args = parser.parse_args()
    folder = (args.keep or Path(tempfile.mkdtemp(prefix="plan-hashes-"))).resolve()
    folder.mkdir(parents=True, exist_ok=True)
    result = {}
    for name, (image, options) in CASES.items():
        if args.only and name not in args.only:
            continue
        photo = _write_photo(image, folder)
        svg, gcode = f"{name}.svg", f"{name}.gcode"
        _pencilbot(folder, "plan", photo.name, "-o", svg, "-q", *options)
        _pencilbot(folder, "export", svg, "-o", gcode, "-q")
        result[name] = {"svg": _sha(folder / svg), "gcode": _sha(folder / gcode)}
    if not args.only or "coffee_optimized" in args.only:
        plan = folder / "coffee.svg"
        if not plan.exists():
            _pencilbot(folder, "plan", _write_photo("coffee", folder).name, "-o", plan.name, "-q")
        _reversed_paths_svg(plan, folder / "coffee_reversed.svg")
        _pencilbot(folder, "optimize", "coffee_reversed.svg", "-o", "coffee_optimized.svg", "-q")
        result["coffee_optimized"] = {"svg": _sha(folder / "coffee_optimized.svg")}
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
