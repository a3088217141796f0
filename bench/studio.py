"""Studio latency: from a control change on the page to the first (coarse) preview and to the
full one, for coffee (600×400), a 1 MP photo (astronaut upscaled to 1024×1024) and a 24 MP one
(6000×4000), on A4 with the default style; and the 1 MP photo with every pen set (cmyk among
them), whose coarse preview the studio holds to 0.5 s.

A real studio server (uvicorn on 127.0.0.1) gets each change as the page sends it (``POST
/api/drawing``: the pen width stepped through 0.45, 0.5, 0.55, 0.6 mm); the clock stops when the
stage's preview PNG has been fetched over HTTP (``GET /api/picture/…``). Also printed: the same
options planned in-process (:func:`pencilbot.api.sketch_and_plan` + the full stage's figures,
warm), the "planning time" the full preview is held to, and ``superseded``: a change sent while
the previous one was still planning, whose result must never arrive (count of results of an
older generation shown: 0).

Timings share 2 cores with other work: they are noisy, rerun before concluding.
Usage: ``python bench/studio.py [--changes 3] [--cases coffee,1mp,24mp,1mp-cmyk,...]``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

from PIL import Image
from skimage import data

from pencilbot.studio.options import DrawingOptions
from pencilbot.studio.planner import plan_stage
from pencilbot.studio.server import prepare

WIDTHS = (0.45, 0.5, 0.55, 0.6)


def photos(folder: Path) -> dict[str, Path]:
    coffee = folder / "coffee.png"
    Image.fromarray(data.coffee()).save(coffee)
    big = folder / "astronaut-1mp.png"
    Image.fromarray(data.astronaut()).resize((1024, 1024), Image.LANCZOS).save(big)
    huge = folder / "astronaut-24mp.jpg"  # a camera's photo: JPEG
    Image.fromarray(data.astronaut()).resize((6000, 4000), Image.BICUBIC).save(huge, quality=90)
    return {"coffee": coffee, "1mp": big, "24mp": huge}


def cases(folder: Path) -> dict[str, tuple[Path, str]]:
    """name → (photo, pen set): each photo with one black pen, the 1 MP one with every pen set."""
    from pencilbot.machine.pens import list_pen_sets

    made = photos(folder)
    found = {name: (path, "") for name, path in made.items()}
    found.update({f"1mp-{pens}": (made["1mp"], pens) for pens in list_pen_sets()})
    return found


def request(
    url: str, body: bytes | None = None, method: str = "GET", kind: str = "application/json"
) -> bytes:
    made = urllib.request.Request(
        url, data=body, method=method, headers={"X-Studio": "1", "Content-Type": kind}
    )
    with urllib.request.urlopen(made, timeout=120) as answer:
        return answer.read()


def wait_stage(studio, generation: int, stage: str, timeout: float = 120.0):
    """The result of ``stage`` for ``generation`` once it is there."""
    seen, end = -1, time.monotonic() + timeout
    while time.monotonic() < end:
        result = studio.results.get(stage)
        if result is not None and result.generation == generation:
            return result
        seen = studio.wait_change(seen, 0.5)
    raise TimeoutError(f"no {stage} result for generation {generation}")


def change(running, width: float, pens: str = "") -> tuple[float, float]:
    """Seconds from the change to the coarse preview fetched, and to the full one."""
    studio, url = running.studio, running.url
    t0 = time.perf_counter()
    body = json.dumps({"pen_width": width, "pens": pens}).encode()
    answer = json.loads(request(url + "api/drawing", body, "POST"))
    generation = answer["generation"]
    times = []
    for stage in ("coarse", "full"):
        result = wait_stage(studio, generation, stage)
        if result.error:
            raise RuntimeError(result.error)
        request(url + f"api/picture/{stage}-preview.png?g={generation}")
        times.append(time.perf_counter() - t0)
    return times[0], times[1]


def superseded(running) -> int:
    """Two changes 50 ms apart: results of the first shown (must be 0)."""
    studio, url = running.studio, running.url
    shown = []
    first = json.loads(request(url + "api/drawing", b'{"pen_width": 0.7}', "POST"))["generation"]
    time.sleep(0.05)
    second = json.loads(request(url + "api/drawing", b'{"pen_width": 0.75}', "POST"))["generation"]
    wait_stage(studio, second, "full")
    shown += [r for r in studio.results.values() if r.generation == first]
    return len(shown)


def measure(path: Path, pens: str, changes: int, check_superseded: bool) -> dict:
    """One photo with one pen set: the page's changes timed, then the same planned in-process."""
    running = prepare(path, listen_port=0)
    thread = threading.Thread(target=running.serve, daemon=True)
    thread.start()
    while not running.server.started:
        time.sleep(0.05)
    wait_stage(running.studio, running.studio.planner.generation, "full")
    coarse, full = [], []
    for width in (WIDTHS * 4)[:changes]:
        c, f = change(running, width, pens)
        coarse.append(c)
        full.append(f)
    dropped_shown = superseded(running) if check_superseded else None
    running.stop()
    thread.join(timeout=10)
    options = DrawingOptions(pen_width=0.5, pens=pens)
    plan_stage(path, options, "full")  # warm
    t0 = time.perf_counter()
    plan_stage(path, options, "full")
    planning = time.perf_counter() - t0
    with Image.open(path) as img:
        size = img.size
    return {
        "pixels": f"{size[0]}x{size[1]}",
        "pens": pens or "one black pen",
        "changes": len(coarse),
        "first_preview_s": {"median": round(statistics.median(coarse), 3), "max": round(max(coarse), 3)},
        "full_preview_s": {"median": round(statistics.median(full), 3), "max": round(max(full), 3)},
        "planning_in_process_s": round(planning, 3),
        **({"superseded_results_shown": dropped_shown} if check_superseded else {}),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--changes", type=int, default=3)
    parser.add_argument("--cases", default="", help="comma-separated case names (default: all)")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="bench-studio-"))
    chosen = [name for name in args.cases.split(",") if name]
    results: dict[str, object] = {}
    for name, (path, pens) in cases(folder).items():
        if chosen and name not in chosen:
            continue
        results[name] = measure(path, pens, args.changes, check_superseded=name == "coffee")
        results["load_average_1min"] = round(os.getloadavg()[0], 2)  # on 2 cores: above 2, others share them
    print(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
