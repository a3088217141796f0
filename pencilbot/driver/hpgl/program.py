"""An HP-GL program before it is sent: every position within the plotter's limits
(:func:`check_limits`), the plot time after each entry for the progress display
(:func:`seconds_after`)."""

from __future__ import annotations

import numpy as np

from pencilbot.errors import PlotError
from pencilbot.machine.motion import axis_scale, move_times


def seconds_after(program, plotter) -> np.ndarray:
    """The plot time (s) after each entry, for the progress display: each move from rest to rest
    at its speed (VS pen down, else the profile's) with the profile's acceleration, as the
    virtual plotter times it, each lift and drop its delay."""
    if not len(program):
        return np.zeros(1)
    step = np.diff(program.xy, axis=0, prepend=np.zeros((1, 2), np.int64)) * plotter.paper.unit_mm
    length = np.hypot(*step.T)
    speed = np.where(
        program.down,
        np.where(program.speed > 0, program.speed * 10.0, plotter.motion.draw_speed),
        plotter.motion.travel_speed,
    )
    moving = length > 0
    units = np.where(moving[:, None], step / np.where(moving, length, 1.0)[:, None], 1.0)
    seconds = np.where(
        moving, move_times(length, 0.0, 0.0, speed, plotter.motion.acceleration * axis_scale(units)), 0.0
    )
    pen = plotter.pen_model
    changed = np.diff(program.down.astype(np.int8), prepend=np.int8(0))
    delays = np.where(changed > 0, pen.down_delay, np.where(changed < 0, pen.up_delay, 0.0))
    return np.cumsum(seconds + delays)


def check_limits(program, plotter, fw, name) -> None:
    """Every position within the bed (the plotter's hard-clip limits), before the port opens."""
    if not len(program):
        return
    w, h = round(plotter.bed.width / plotter.paper.unit_mm), round(plotter.bed.height / plotter.paper.unit_mm)
    bad = np.flatnonzero(
        (program.xy[:, 0] < 0) | (program.xy[:, 1] < 0) | (program.xy[:, 0] > w) | (program.xy[:, 1] > h)
    )
    if len(bad):
        k = bad[0]
        raise PlotError(
            f"{name}: instruction {program.lines[k]} goes to {program.xy[k, 0]},{program.xy[k, 1]}, beyond the limits of "
            f"{plotter.name} (0..{w} x 0..{h} plotter units); export the drawing for this sheet"
        )
