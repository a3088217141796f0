"""A feed hold on the virtual GRBL, over any path and any moment: the machine slows along the
path it was taking and stands no further than its stopping distance, the planner never holds
more blocks than it has slots, and after the cycle start the drawing is the one an
uninterrupted run makes."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from machines import description

from sim.faults import Faults
from sim.gcode.firmware import Firmware
from sim.gcode.machine import Machine

ACCEL = 800.0  # mm/s², the description's on every axis (the least along any direction)

# (To the G-code's three decimals, so the path is exactly what the board is sent.)
coordinate = st.floats(5, 60).map(lambda v: round(v, 3))
points = st.lists(st.tuples(coordinate, coordinate), min_size=2, max_size=12)


def run(path, hold_at=None, stand=0.5):
    """Draw ``path`` at 50 mm/s on a real-time board; with ``hold_at`` (s from the start),
    press hold there, let it stand ``stand`` s and go on. Returns (board, where the hold began,
    its speed, where it stood, the blocks it held)."""
    fw = Firmware(Machine(description(), instant=False))
    fw.take_output()
    fw.receive(b"G0X%.3fY%.3f\nM3S90\n" % path[0] + b"".join(b"G1X%.3fY%.3fF3000\n" % p for p in path[1:]))
    seen = None
    if hold_at is not None:
        fw.poll(hold_at)
        m = fw.machine
        began, speed, blocks = m.machine_position(), m.current_speed(), len(m.planner)
        fw.receive(b"!")
        assert len(m.planner) <= blocks  # slowing cuts blocks, it adds none
        fw.poll(stand)
        assert fw.state() == "Hold:0" and m.planner.free_blocks >= 0
        seen = began, speed, m.machine_position()
        fw.receive(b"~")
    for _ in range(50):
        fw.poll(1.0)
    return fw, seen


def along(path, point):
    """Every distance along ``path`` (from its start) at which it passes ``point`` (within 1 µm)."""
    found, travelled = [], 0.0
    for a, b in zip(path, path[1:]):
        a, b = np.array(a), np.array(b)
        seg = b - a
        length = float(np.hypot(*seg))
        if length > 0:
            t = float(np.clip(np.dot(np.array(point[:2]) - a, seg) / length**2, 0.0, 1.0))
            if np.hypot(*(a + t * seg - point[:2])) < 1e-6:
                found.append(travelled + t * length)
        travelled += length
    return found


@settings(max_examples=60, deadline=None)
@given(path=points, hold_at=st.floats(0.0, 2.0))
def test_a_hold_anywhere_stands_within_the_stopping_distance_and_draws_what_an_uninterrupted_run_draws(
    path, hold_at
):
    uninterrupted, _ = run(path)
    held, (began, speed, stood) = run(path, hold_at)
    drawn = [p for stroke in held.machine.strokes for p in stroke]
    reference = {tuple(np.round(p, 6)) for stroke in uninterrupted.machine.strokes for p in stroke}
    # Every corner of the uninterrupted drawing is drawn, the only new points lie on the path
    # (the stand point splits a move), and no stretch is drawn twice.
    assert reference <= {tuple(np.round(p, 6)) for p in drawn}
    assert all(along(path, p) for p in drawn)
    assert (
        _length(held.machine.strokes) == np.float64(_length(uninterrupted.machine.strokes)).round(6)
        or abs(_length(held.machine.strokes) - _length(uninterrupted.machine.strokes)) < 1e-6
    )
    if speed == 0:
        assert stood == began  # nothing moving: it holds where it is
        return
    # It stands on its way (the travel from home, then the path), at or past where the hold
    # began, within v²/2a of it.
    way = [(0.0, 0.0), *path]
    starts, ends = along(way, began), along(way, stood)
    assert any(0 <= e - s <= speed**2 / (2 * ACCEL) + 1e-6 for s in starts for e in ends)


def _length(strokes) -> float:
    return float(sum(np.hypot(*np.diff(s, axis=0).T).sum() for s in strokes))


def test_a_fault_at_a_moment_is_a_finite_time_after_power_on_or_a_plain_error():
    assert Faults.parse("interrupt@1.45s,hold@2s:0").timed == [(1.45, "interrupt", 2), (2.0, "hold", 0)]
    for spec in ("hold@0s", "interrupt@" + "9" * 400 + "s", "interrupt@nans", "interrupt@1e308s", "error@2s"):
        with pytest.raises(ValueError, match="fault"):
            Faults.parse(spec)
