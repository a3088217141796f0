"""The full hostile sweep of issue 33: every probe of ``tests/hostile/sweep.py`` (CLI commands ×
bad files, G-code lines, HP-GL, profiles of every family, the user's settings), run in one child
process under a 2 GB limit with a 20 s alarm a probe. Prints JSON: per surface the probes, clean
errors, correct runs (right inputs) and failures (traceback, hang, exit 0 on a wrong input, more
than one error line, a file replaced or left behind), with each failure named.

    python bench/hostile.py            # all of them (about 2 minutes)
    python bench/hostile.py --sample 60
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path[:0] = [str(Path(__file__).resolve().parents[1] / "tests" / sub) for sub in ("hostile", "")]

import sweep  # noqa: E402 - found through the path set just above


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sample", type=int, default=0, help="run about this many probes (0: all)")
    parser.add_argument(
        "--seconds", type=float, default=sweep.SECONDS, help="a probe's alarm (default %(default)g)"
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="hostile-") as folder:
        every = sweep.probes(Path(folder))
        chosen = sweep.sample(every, args.sample) if args.sample else every
        start = time.perf_counter()
        results = sweep.run(chosen, Path(folder), args.seconds)
        seconds = time.perf_counter() - start
    table = sweep.counts(results)
    total = {
        key: sum(row[key] for row in table.values())
        for key in ("probes", "clean errors", "correct", "failures")
    }
    print(
        json.dumps(
            {"surfaces": table, "total": total, "seconds": round(seconds, 1)}, indent=1, ensure_ascii=False
        )
    )


if __name__ == "__main__":
    main()
