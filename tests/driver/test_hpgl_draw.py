"""A plan of coffee exported as HP-GL and drawn over sim:// on the virtual HP 7475A: what the
plotter draws is the plan to a plotter unit, every stroke once, in the estimated time; a job
stopped by Ctrl-C resumes exactly once; a resume that cannot prove the pen's position is refused."""

from __future__ import annotations

import os
import signal
from contextlib import contextmanager
from dataclasses import replace

import numpy as np
import pytest
import skimage.data
from segments import drawing_differences

import sim
from pencilbot import api
from pencilbot.driver import draw
from pencilbot.driver.journal import load_journal
from pencilbot.errors import PlotError
from pencilbot.export.hpgl import SheetPlacement, hpgl_plan, write_hpgl
from pencilbot.machine.profile import load_profile
from pencilbot.planning.stats import estimate
from sim import protocol_sim

UNIT = load_profile("hp7475a").paper.unit_mm  # mm per plotter unit (0.02488 on the 7475A)


@pytest.fixture(scope="module")
def coffee():
    sim.register()
    profile = load_profile("hp7475a")
    return api.plan(skimage.data.coffee()[::2, ::2]), profile  # half size: the same picture, planned sooner


def _fresh(name):
    protocol_sim.forget(name)
    return f"sim://{name}?profile=hp7475a"


def test_coffee_round_trip_every_stroke_once_to_a_plotter_unit(coffee, tmp_path):
    plan, profile = coffee
    target = tmp_path / "coffee.hpgl"
    write_hpgl(plan, profile, target)
    draw(target, _fresh("hpgl-rt"), profile="hp7475a")
    board = protocol_sim.plotter("hpgl-rt").board
    drawn = board.strokes
    paths = plan.paths()
    assert len(drawn) == len(paths)  # every stroke once, in order
    placement = SheetPlacement.of(plan.page, profile)
    worst = 0.0
    for got, want in zip(drawn, paths):
        want = placement.to_machine(want)
        units = np.rint(want / UNIT)
        keep = np.ones(len(units), bool)
        keep[1:] = np.any(units[1:] != units[:-1], axis=1)
        want = want[keep]
        assert got.shape == want.shape
        worst = max(worst, float(np.abs(got - want).max()))
    assert worst <= UNIT / 2 + 1e-9  # rounding to the nearest plotter unit, nothing more
    # Plot time: the simulator's clock against the one estimate, within 2 %.
    seconds = estimate(plan, profile).total.seconds
    assert abs(board.clock / seconds - 1) < 0.02, (board.clock, seconds)
    assert board.overflows == 0 and board.max_fill <= profile.receive_buffer - 128
    # stat reads the file back into the same strokes (page mm).
    back = hpgl_plan(target, profile)
    assert len(back.paths()) == len(paths)


@contextmanager
def _ctrl_c_at(count: int, monkeypatch, signum=signal.SIGINT):
    """Ctrl-C (or ``signum``) comes as the virtual plotter starts its ``count``-th instruction."""
    from sim.hpgl.board import HpglBoard

    run = HpglBoard._run

    def pressing(self, ins):
        run(self, ins)
        if self.executed == count:
            os.kill(os.getpid(), signum)

    monkeypatch.setattr(HpglBoard, "_run", pressing)
    yield
    monkeypatch.setattr(HpglBoard, "_run", run)


def _small_job(plan, profile, tmp_path, count=80):
    layer = plan.layers[0]
    small = replace(plan, layers=(replace(layer, paths=layer.paths[:count]),))
    target = tmp_path / "small.hpgl"
    write_hpgl(small, profile, target)
    return target


@pytest.mark.parametrize("signum, name", [(signal.SIGINT, "Ctrl-C"), (signal.SIGTERM, "SIGTERM")])
def test_ctrl_c_stops_and_the_resume_draws_the_rest_exactly_once(signum, name, coffee, tmp_path, monkeypatch):
    plan, profile = coffee
    target = _small_job(plan, profile, tmp_path)
    draw(target, _fresh("hpgl-ref"), profile="hp7475a")
    reference = protocol_sim.plotter("hpgl-ref").board.strokes

    # The virtual plotter fast but not instant, so the buffer holds work when Ctrl-C comes; Ctrl-C
    # is pressed when the plotter starts its 300th instruction (a fixed point of the job).
    port = _fresh("hpgl-stop").replace("profile=", "realtime=200&xonxoff=1&profile=")
    with (
        _ctrl_c_at(300, monkeypatch, signum),
        pytest.raises(PlotError, match=f"stopped by {name}; stopped after instruction"),
    ):
        draw(target, port, profile="hp7475a")
    journal = load_journal(target)
    assert journal.status == "stopped" and journal.stop_work is not None
    board = protocol_sim.plotter("hpgl-stop").board
    assert not board.down and board.executed >= 300
    assert journal.next_line < journal.total_lines  # the abort left part of the job undrawn
    draw(target, port, resume=str(journal.path))
    assert not journal.path.exists()
    assert drawing_differences(board.strokes, reference) == []


def test_a_resume_after_a_power_cycle_is_refused(coffee, tmp_path, monkeypatch):
    plan, profile = coffee
    target = _small_job(plan, profile, tmp_path, count=40)
    halfway = len(profile.firmware.program(target.read_bytes())) // 2
    port = _fresh("hpgl-power").replace("profile=", "realtime=200&profile=")
    with _ctrl_c_at(halfway, monkeypatch), pytest.raises(PlotError, match="stopped by Ctrl-C"):
        draw(target, port, profile="hp7475a")
    protocol_sim.plotter("hpgl-power").board.power_cycle()  # someone switched it off and on
    with pytest.raises(PlotError, match="cannot resume .* exactly"):
        draw(target, port, resume=str(target))


def test_an_unplugged_cable_resumes_after_what_was_sent_exactly_once(coffee, tmp_path):
    plan, profile = coffee
    target = _small_job(plan, profile, tmp_path)
    draw(target, _fresh("hpgl-ref2"), profile="hp7475a")
    reference = protocol_sim.plotter("hpgl-ref2").board.strokes
    port = _fresh("hpgl-drop").replace("profile=", "faults=drop@400&profile=")
    with pytest.raises(PlotError, match="the port was lost"):
        draw(target, port, profile="hp7475a")
    board = protocol_sim.plotter("hpgl-drop").board
    draw(target, port, resume=str(target))  # plugged back in: the plotter drew what it held
    assert drawing_differences(board.strokes, reference) == []


def test_a_lost_answer_and_line_noise_cost_nothing(coffee, tmp_path):
    plan, profile = coffee
    target = _small_job(plan, profile, tmp_path, count=30)
    draw(target, _fresh("hpgl-ref3"), profile="hp7475a")
    reference = protocol_sim.plotter("hpgl-ref3").board.strokes
    draw(
        target,
        _fresh("hpgl-noise").replace("profile=", "faults=silent@50,garbage@120&profile="),
        profile="hp7475a",
        timeout=1.0,
    )
    assert drawing_differences(protocol_sim.plotter("hpgl-noise").board.strokes, reference) == []


@pytest.mark.parametrize("where", [0.5, 0.95])
def test_a_power_cycle_while_drawing_stops_the_job_and_its_resume_is_refused(where, coffee, tmp_path):
    # Near the end, the reset empties the buffer and the driver sends the rest before a sync
    # point shows the loss: the journal's next instruction is past the last, and the resume
    # must still be refused for the position (not for the line number).
    plan, profile = coffee
    target = _small_job(plan, profile, tmp_path, count=60)
    at = int(len(profile.firmware.program(target.read_bytes())) * where)
    port = _fresh("hpgl-reset").replace("profile=", f"faults=reset@{at}&profile=")
    with pytest.raises(PlotError, match="lost its place"):
        draw(target, port, profile="hp7475a")
    with pytest.raises(PlotError, match="cannot resume .* exactly"):
        draw(target, port, resume=str(target))


def test_a_reset_after_everything_was_sent_is_caught_though_the_pen_ends_at_home(tmp_path):
    # The job parks at home, pen up: where a power cycle leaves the pen too. The reset comes as
    # the plotter starts the last line, after the driver sent everything: the final sync point
    # (OA) answers where the program ends, and only the status byte (OS bit 8) tells the loss.
    sim.register()
    target = tmp_path / "home.hpgl"
    target.write_bytes(b"IN;SP1;PU400,400;PD800,400;PD800,800;PD400,800;PU0,0;SP0;")
    draw(target, _fresh("hpgl-home-ref"), profile="hp7475a")
    log = protocol_sim.plotter("hpgl-home-ref").board.log
    last_line = max(i for i, ins in enumerate(log) if ins.startswith("PD")) + 1  # 1-based, as faults count
    port = _fresh("hpgl-home").replace("profile=", f"faults=reset@{last_line}&profile=")
    with pytest.raises(PlotError, match="lost its place"):
        draw(target, port, profile="hp7475a")
    board = protocol_sim.plotter("hpgl-home").board
    assert [s.tolist() for s in board.strokes] == (
        np.array([[[400, 400], [800, 400], [800, 800]]]) * UNIT
    ).tolist()  # the last line: never
    assert (board.x, board.y, board.down) == (0, 0, False)
    journal = load_journal(target)
    assert journal.status == "stopped" and journal.stop_work is None
    with pytest.raises(PlotError, match="cannot resume .* exactly"):
        draw(target, port, resume=str(target))


class _KeysAt:
    """The terminal's pause key, pressed once as the plotter starts its ``at``-th instruction."""

    def __init__(self, name, at):
        self.name, self.at, self.pressed = name, at, False

    def poll(self):
        if not self.pressed and protocol_sim.plotter(self.name).board.executed >= self.at:
            self.pressed = True
            return ["pause"]
        return []


class _Person:
    """Someone at the plotter: notes each prompt and the plotter's state when it came."""

    def __init__(self, name):
        self.name, self.seen = name, []

    def pause(self, prompt):
        board = protocol_sim.plotter(self.name).board
        board.poll(0.0)
        self.seen.append((prompt, board.down, bytes(board.buffer), board.pen))


def test_the_pause_key_stops_at_once_and_goes_on_from_the_very_instruction(coffee, tmp_path):
    plan, profile = coffee
    target = _small_job(plan, profile, tmp_path)
    draw(target, _fresh("hpgl-pref"), profile="hp7475a")
    reference = protocol_sim.plotter("hpgl-pref").board.strokes
    name = "hpgl-pause"
    person = _Person(name)
    # Fast but not instant, so the buffer holds work the pause discards and sends again.
    draw(
        target,
        _fresh(name).replace("profile=", "realtime=200&profile="),
        profile="hp7475a",
        operator=person,
        keys=_KeysAt(name, 300),
    )
    assert [prompt for prompt, *_ in person.seen] == ["paused: the pause key"]
    assert all(not down and not buffer for _, down, buffer, _ in person.seen)  # at rest, pen up
    assert drawing_differences(protocol_sim.plotter(name).board.strokes, reference) == []


def _eight_pens(tmp_path):
    from pencilbot.paths import Paths
    from pencilbot.planning.plan import Layer, Page, Plan

    layers = [
        Layer(
            f"l{k}",
            Paths.of([np.array([[20.0 + 30 * k, 40.0], [45.0 + 30 * k, 60.0], [46.0 + 30 * k, 120.0]])]),
            pen=f"pen{k + 1}",
        )
        for k in range(8)
    ]
    plan = Plan(Page(297, 210, margin=0.0, name="A4"), layers)
    target = tmp_path / "eight.hpgl"
    write_hpgl(plan, load_profile("hp7475a"), target)
    placement = SheetPlacement.of(plan.page, load_profile("hp7475a"))
    return target, [placement.to_machine(p) for p in plan.paths()]


def test_a_pen_the_carousel_lacks_pauses_with_the_pen_put_away_and_draws_in_its_slot(tmp_path):
    target, reference = _eight_pens(tmp_path)
    name = "hpgl-pens"
    person = _Person(name)
    draw(target, _fresh(name), profile="hp7475a", operator=person)
    assert [prompt for prompt, *_ in person.seen] == [
        "paused: pen change: put pen 7 in carousel slot 1 (in place of pen 1)",
        "paused: pen change: put pen 8 in carousel slot 2 (in place of pen 2)",
    ]
    # Everything before ran, the pen is up and back in the carousel (its slot can be filled).
    assert all(not down and not buffer and pen == 0 for _, down, buffer, pen in person.seen)
    board = protocol_sim.plotter(name).board
    assert board.stroke_pens == [1, 2, 3, 4, 5, 6, 1, 2] and board.error == 0
    assert drawing_differences(board.strokes, reference, tolerance=UNIT) == []


def test_a_pen_change_with_nobody_at_the_terminal_stops_and_the_resume_asks_for_the_pen(tmp_path):
    target, reference = _eight_pens(tmp_path)
    name = "hpgl-pens-alone"
    with pytest.raises(PlotError, match=r"a pen change \(pen change: put pen 7 .*nobody at the terminal"):
        draw(target, _fresh(name), profile="hp7475a")
    board = protocol_sim.plotter(name).board
    assert board.stroke_pens == [1, 2, 3, 4, 5, 6] and board.pen == 0  # pen 6 put away
    person = _Person(name)
    draw(target, f"sim://{name}", resume=str(target), operator=person)
    assert [prompt for prompt, *_ in person.seen] == [
        "paused: pen change: put pen 7 in carousel slot 1 (in place of pen 1)",
        "paused: pen change: put pen 8 in carousel slot 2 (in place of pen 2)",
    ]
    assert board.stroke_pens == [1, 2, 3, 4, 5, 6, 1, 2]
    assert drawing_differences(board.strokes, reference, tolerance=UNIT) == []


def test_the_buffer_is_never_filled_to_the_brim(tmp_path):
    """A real 7475A filled to exactly the free bytes ESC.B reported overflowed: the sender keeps
    128 bytes (the plotter's XON threshold) free, and still keeps the rest of the buffer busy."""
    sim.register()
    target = tmp_path / "long.hpgl"
    target.write_bytes(
        b"IN;SP1;"
        + b"".join(
            b"PU%d,400;PD%d,2000,%d,2000;" % (400 + 3 * i, 400 + 3 * i, 410 + 3 * i) for i in range(150)
        )
        + b"PU;SP0;"
    )
    draw(target, _fresh("hpgl-brim").replace("profile=", "tick=0.5&profile="), profile="hp7475a")
    board = protocol_sim.plotter("hpgl-brim").board
    size = load_profile("hp7475a").receive_buffer
    assert board.overflows == 0 and size - 128 - 32 <= board.max_fill <= size - 128
