"""Imported by the planner's fork server: plans a tiny picture once, so that every lazily
imported module and first-call cache is ready in the processes forked from it."""

from __future__ import annotations

import numpy as np


def warm() -> None:
    from pencilbot.studio.options import DrawingOptions
    from pencilbot.studio.planner import plan_stage

    ramp = np.linspace(0.0, 1.0, 80 * 128, dtype=np.float32).reshape(80, 128)  # a tiny picture
    for stage in ("coarse", "full"):
        plan_stage(ramp, DrawingOptions(), stage)


warm()
