"""An HP-GL file written by vpype (`write --device hp7475a`: relative PR moves, many points per
PD, one pen per layer) is read by `stat` and drawn by the virtual HP-GL plotter where vpype put
each stroke: the same strokes as pencilbot's own HP-GL of the plan, to a plotter unit: vpype's
plotter unit (0.02488 mm in its device table) is the 7475A's, as pencilbot's profile has it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import sim
from pencilbot.driver import draw
from pencilbot.export.hpgl import hpgl_plan, write_hpgl
from pencilbot.export.svg import write_svg
from pencilbot.machine.profile import load_profile
from pencilbot.paths import Paths
from pencilbot.planning.plan import Layer, Page, Plan
from sim import protocol_sim

vpype_cli = pytest.importorskip("vpype_cli")
VPYPE_UNIT = 0.02488  # mm: vpype's hp7475a plotter_unit_length


def _plan() -> Plan:
    t = np.linspace(0, 2 * np.pi, 40)
    first = [np.column_stack([150 + r * np.cos(t), 105 + 0.6 * r * np.sin(2 * t)]) for r in range(10, 90, 10)]
    second = [np.array([[x, 30.0], [x + 7.0, 80.0], [x + 2.0, 95.0]]) for x in np.arange(30, 120, 9.0)]
    return Plan(
        Page(297, 210, margin=0.0, name="A4"),
        [Layer("curves", Paths.of(first)), Layer("lines", Paths.of(second))],
    )


def _drawn(path, name):
    protocol_sim.forget(name)
    draw(path, f"sim://{name}?profile=hp7475a", profile="hp7475a")
    board = protocol_sim.plotter(name).board
    return board.strokes, board.stroke_pens


def test_vpype_hpgl_draws_where_vpype_put_it(tmp_path):
    sim.register()
    profile = load_profile("hp7475a")
    plan = _plan()
    write_svg(plan, tmp_path / "plan.svg")
    theirs, ours = tmp_path / "vpype.hpgl", tmp_path / "ours.hpgl"
    vpype_cli.execute(
        f"read {tmp_path / 'plan.svg'} write --device hp7475a --page-size a4 --landscape {theirs}"
    )
    write_hpgl(plan, profile, ours)
    assert b"PR;" in theirs.read_bytes()  # relative moves: the reader follows them

    got, pens = _drawn(theirs, "vpype-theirs")
    want, _ = _drawn(ours, "vpype-ours")
    assert profile.paper.unit_mm == VPYPE_UNIT
    assert len(got) == len(want) == len(plan.paths())
    assert pens == [1] * 8 + [2] * 10  # vpype gives each layer its own carousel pen
    for stroke, reference in zip(got, want):
        gap = max(cKDTree(reference).query(stroke)[0].max(), cKDTree(stroke).query(reference)[0].max())
        assert gap <= 0.05  # a unit of rounding each side
    assert len(hpgl_plan(theirs, profile).layers) == 2  # stat: a layer per pen
