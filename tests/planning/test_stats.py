"""The plan's cost at a plotter: lengths, lifts, and the time of the program the writer makes."""

import dataclasses
import math

import numpy as np
import pytest

from pencilbot.machine.bed import Placement
from pencilbot.machine.motion import Motion, move_times
from pencilbot.machine.profile import load_profile
from pencilbot.planning.plan import Layer, Page, Plan
from pencilbot.planning.stats import Stats, estimate

GRBL = load_profile("grbl-servo-a4")  # bottom-left origin: home is the page's bottom-left corner
IDLE_LOCK = GRBL.firmware.idle_lock  # $1: GRBL stands still 25 ms each time the motion comes to rest


def profile(base=GRBL, *, up_delay=0.0, down_delay=0.0, **motion):
    """``base`` with other motion limits and pen delays."""
    table = {f.name: getattr(base.motion, f.name) for f in dataclasses.fields(Motion)} | motion
    pen = dataclasses.replace(base.pen, up_delay=up_delay, down_delay=down_delay)
    return dataclasses.replace(base, motion=Motion(**table), pen=pen)


def plan_of(*layers, page=Page(200, 300)):
    return Plan(page, [Layer(name, paths) for name, paths in layers])


def drawn_seconds(stats, p, *hops):
    """Seconds of a plan's drawing alone: its estimate less the GRBL rapids ``hops`` ((dx, dy) mm,
    each from rest to rest; every axis at its own rate, so a diagonal is faster)."""
    rapid = 0.0
    for dx, dy in hops:
        length = math.hypot(dx, dy)
        boost = length / max(abs(dx), abs(dy))
        rapid += move_times(
            np.array([length]), 0, 0, p.motion.axis_rate / 60 * boost, p.motion.acceleration * boost
        )[0]
    return stats.total.seconds - rapid


def test_collinear_points_do_not_slow_the_pen():
    p = profile()
    one = estimate(plan_of(("a", [np.array([[0.0, 0.0], [100.0, 0.0]])])), p).total
    many = estimate(plan_of(("a", [np.column_stack([np.linspace(0, 100, 51), np.zeros(51)])])), p).total
    assert many.seconds == pytest.approx(one.seconds)
    assert (one.segments, many.segments) == (1, 50)


def test_reversal_stops_and_right_angle_follows_junction_deviation():
    p = profile(draw_feed=3000, acceleration=200, junction_deviation=0.05)
    single = move_times(np.array([20.0]), 0, 0, 50, 200)[0]
    back = estimate(plan_of(("a", [np.array([[0.0, 0], [20, 0], [0, 0]])])), p)
    assert drawn_seconds(back, p) == pytest.approx(2 * single + IDLE_LOCK)  # reversing is no rest
    corner = estimate(plan_of(("a", [np.array([[0.0, 0], [20, 0], [20, 20]])])), p)
    v = math.sqrt(200 * 0.05 * math.sqrt(0.5) / (1 - math.sqrt(0.5)))  # GRBL at 90°
    expect = 2 * move_times(np.array([20.0]), 0, v, 50, 200)[0]
    assert drawn_seconds(corner, p, (20, 20)) == pytest.approx(expect + 2 * IDLE_LOCK)  # and the travel home
    looser = profile(draw_feed=3000, acceleration=200, junction_deviation=0.5)
    tighter_corner = estimate(plan_of(("a", [np.array([[0.0, 0], [20, 0], [20, 20]])])), looser)
    assert tighter_corner.total.seconds < corner.total.seconds


def test_travel_lifts_delays_and_layers_add_up():
    p = profile(travel_feed=6000, draw_feed=3000, acceleration=1000, up_delay=0.2, down_delay=0.3)
    a = [np.array([[10.0, 0.0], [20.0, 0.0]]), np.array([[20.0, 10.0], [10.0, 10.0]])]
    b = [np.array([[10.0, 40.0], [10.0, 50.0]]), np.array([[0.0, 50.0]])]
    stats = estimate(plan_of(("hatch", a), ("edges", b)), p)
    h, e = stats.layers["hatch"], stats.layers["edges"]
    assert (h.pen_up_mm, h.pen_down_mm, h.lifts, h.paths, h.segments) == (20.0, 20.0, 2, 2, 2)
    assert e.pen_up_mm == pytest.approx(30.0 + 10.0 + 50.0)  # from hatch's last point; then home
    assert (e.lifts, e.paths, e.segments) == (2, 2, 1)
    rapid = p.motion.axis_rate / 60  # GRBL's G0 runs at the axis rate
    travel = move_times(np.array([10.0, 10.0]), 0, 0, rapid, 1000).sum()
    draw = move_times(np.array([10.0, 10.0]), 0, 0, p.motion.draw_speed, 1000).sum()
    # The first lift, then 2 paths; each travel and each path ends at rest.
    assert h.seconds == pytest.approx(0.2 + travel + draw + 2 * 0.5 + 4 * IDLE_LOCK)
    assert stats.total == h + e
    assert stats.as_dict()["total"]["lifts"] == 4


def test_a_diagonal_rapid_runs_at_both_axes_rates_on_grbl_but_at_its_feed_on_marlin():
    plan = plan_of(("a", [np.array([[100.0, 100.0]])]))
    grbl = estimate(plan, profile(acceleration=1e7)).total.seconds
    assert grbl == pytest.approx(
        2 * math.hypot(100, 100) / (6000 / 60) / math.sqrt(2) + 2 * IDLE_LOCK, rel=1e-3
    )
    marlin = profile(load_profile("marlin-servo-a4"), acceleration=1e7, travel_feed=6000)
    home = Placement.on_bed(plan.page, marlin.bed).home()  # the sheet lies turned on this bed
    hop = math.dist(home, (100.0, 100.0))
    assert estimate(plan, marlin).total.seconds == pytest.approx(2 * hop / 100, rel=1e-3)


def test_a_z_pen_spends_its_z_travel_on_every_lift_and_drop():
    z = load_profile("grbl-z-a3")
    plan = plan_of(("a", [np.array([[100.0, 100.0], [120.0, 100.0]])]))
    lift = move_times(
        np.array([z.pen.up - z.pen.down]), 0, 0, z.motion.axis_rate / 60, z.motion.acceleration
    )[0]
    no_z = estimate(
        plan, dataclasses.replace(z, pen=dataclasses.replace(z.pen, up=0.0, down=0.0))
    ).total.seconds
    # Three Z moves (the first lift, the drop, the lift); GRBL takes the corners between them and
    # the XY moves without stopping, so each costs a little less than a move from rest to rest.
    # (tests/test_agreement.py holds the estimate to the virtual plotter's planner.)
    assert no_z + 2 * lift < estimate(plan, z).total.seconds < no_z + 3 * lift


def test_empty_plan_costs_the_first_lift_only():
    p = profile(up_delay=0.25)
    stats = estimate(plan_of(("edges", [])), p)
    assert stats.total == Stats(seconds=0.25) and stats.layers["edges"] == Stats(seconds=0.25)
    assert estimate(Plan(Page(100, 100)), p).total == Stats(seconds=0.25)
