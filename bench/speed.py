"""Time and peak memory of the imaging stages; prints JSON.

    python bench/speed.py                      # every stage on every image
    python bench/speed.py --stage line_drawing --image coffee

Each (stage, image) runs in a fresh subprocess. Peak memory is the kernel's peak resident set
size (VmHWM), reset just before the stage runs, so it counts OpenCV's and numpy's allocations
alike (tracemalloc would miss OpenCV's) and excludes making the test image. It still includes the
interpreter, the libraries and the input image; ``baseline_bytes`` is the resident size just
before the stage, so ``peak_bytes − baseline_bytes`` is what the stage itself added.
Times are the median of several runs after one warm-up run. The machine is shared: expect noise.

To benchmark another stage, add ``name: (prepare, run)`` to ``STAGES`` (and a target to
``TARGETS`` if the issue sets one).
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import cv2
import skimage.data

from pencilbot.imaging.gmed import edge_map
from pencilbot.imaging.io import LoadedImage, image_from_array
from pencilbot.imaging.pencil import sketch
from pencilbot.imaging.strokes import line_drawing


def _photo(height: int, width: int) -> LoadedImage:
    """skimage's astronaut resampled to (height, width), standing in for a camera photo."""
    rgb = cv2.resize(skimage.data.astronaut(), (width, height), interpolation=cv2.INTER_CUBIC)
    return image_from_array(rgb, source=f"astronaut {width}×{height}")


IMAGES = {
    "coffee": lambda: image_from_array(skimage.data.coffee(), source="skimage coffee 600×400"),
    "1MP": lambda: _photo(1000, 1000),
    "12MP": lambda: _photo(3000, 4000),
}
REPEATS = {"coffee": 15, "1MP": 7, "12MP": 3}


# name -> (prepare, run): prepare(image) is untimed and returns run's input; run is timed.
STAGES = {
    "gmed": (lambda image: image.gray, edge_map),
    "strokes": (lambda image: edge_map(image.gray), line_drawing),
    "line_drawing": (lambda image: image.gray, lambda gray: line_drawing(edge_map(gray))),
    # The whole paper pipeline: lines, tone, texture, β, R = L·T (per-stage times reported too).
    "sketch": (lambda image: image, sketch),
    "sketch_color": (lambda image: image, lambda image: sketch(image, color=True)),
}
GIB = 2**30
TARGETS = {
    ("line_drawing", "coffee"): {"seconds": 0.060},
    ("line_drawing", "1MP"): {"seconds": 0.250},
    ("line_drawing", "12MP"): {"seconds": 4.0, "peak_bytes": 2 * GIB},
    **{
        (stage, image): target
        for stage in ("sketch", "sketch_color")
        for image, target in [
            ("coffee", {"seconds": 0.3}),
            ("1MP", {"seconds": 1.2}),
            ("12MP", {"seconds": 20.0, "peak_bytes": 3 * GIB}),
        ]
    },
}


def _status_bytes(field: str) -> int:
    """A memory figure from /proc/self/status (Linux), e.g. VmRSS or VmHWM (peak RSS), in bytes."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) * 1024
    raise RuntimeError(f"{field} missing from /proc/self/status")


def _reset_peak() -> None:
    """Reset the kernel's peak-RSS counter (VmHWM) so the peak is this stage's, not the set-up's."""
    Path("/proc/self/clear_refs").write_text("5")


def measure(stage: str, image_name: str) -> dict:
    """Run one stage on one image in this process (called in the worker subprocess)."""
    image = IMAGES[image_name]()
    prepare, run = STAGES[stage]
    data = prepare(image)
    gc.collect()
    _reset_peak()
    baseline = _status_bytes("VmRSS")
    run(data)  # warm-up: first-call allocations, OpenCV thread pool start
    times = []
    stage_times: dict[str, list[float]] = {}  # a Sketch's own per-stage timings
    for _ in range(REPEATS[image_name]):
        start = time.perf_counter()
        out = run(data)
        times.append(time.perf_counter() - start)
        for name, seconds in getattr(out, "timings", {}).items():
            stage_times.setdefault(name, []).append(seconds)
    extra = {}
    if stage_times:
        extra["stage_seconds_median"] = {
            name: round(statistics.median(t), 4) for name, t in stage_times.items()
        }
    if getattr(out, "fit", None) is not None:
        extra["cg"] = {"iterations": out.fit.iterations, "residual": out.fit.residual, "block": out.fit.block}
    return {
        "stage": stage,
        "image": image_name,
        "shape": list(image.shape),
        "megapixels": round(image.gray.size / 1e6, 2),
        "seconds_median": round(statistics.median(times), 4),
        "seconds_min": round(min(times), 4),
        "repeats": len(times),
        "peak_bytes": _status_bytes("VmHWM"),
        "baseline_bytes": baseline,
        **extra,
    }


def _run_worker(stage: str, image_name: str) -> dict:
    proc = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), "--worker", "--stage", stage, "--image", image_name],
        capture_output=True,
        text=True,
        check=True,
    )
    result = json.loads(proc.stdout)
    target = TARGETS.get((stage, image_name))
    if target:
        result["target"] = target
        result["met"] = result["seconds_median"] <= target["seconds"] and result["peak_bytes"] <= target.get(
            "peak_bytes", float("inf")
        )
    result["peak_gib"] = round(result["peak_bytes"] / GIB, 3)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stage", choices=sorted(STAGES), action="append", help="default: all")
    parser.add_argument("--image", choices=list(IMAGES), action="append", help="default: all")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(measure(args.stage[0], args.image[0])))
        return
    results = [
        _run_worker(stage, image_name)
        for stage in (args.stage or list(STAGES))
        for image_name in (args.image or list(IMAGES))
    ]
    print(json.dumps({"cpus": len(os.sched_getaffinity(0)), "results": results}, indent=2))


if __name__ == "__main__":
    main()
