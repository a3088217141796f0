"""Machine control (pencilbot.driver.control) on every family's virtual plotter: what the library
says the pen is must be what the virtual board's own record says, walks must move the real
carriage, motors off must release the motors the board has, and what a family cannot do is one
PlotError."""

from __future__ import annotations

import numpy as np
import pytest

import sim
from pencilbot.driver.control import open_control
from pencilbot.errors import PencilbotError, PlotError
from sim import protocol_sim

sim.register()

FAMILIES = ["axidraw-v3", "grbl-servo-a4", "grbl-z-a3", "grblhal-servo-a3", "hp7475a"]


@pytest.fixture
def name(request):
    key = "control-" + "".join(c if c.isalnum() else "-" for c in request.node.name)
    yield key
    protocol_sim.forget(key)


def board_pen_down(plotter) -> bool:
    """The virtual board's own record of its pen (not what the driver asked for)."""
    board = plotter.firmware
    if hasattr(board, "pen_up"):  # EBB: the servo's state
        return not board.pen_up
    return bool(plotter.machine.pen_down if hasattr(plotter.machine, "pen_down") else board.down)


def carriage_mm(plotter) -> np.ndarray:
    """Where the virtual carriage really is, machine mm."""
    if hasattr(plotter, "position"):
        return np.asarray(plotter.position(), float)[:2]
    if hasattr(plotter.machine, "carriage_position"):
        return np.asarray(plotter.machine.carriage_position(), float)[:2]
    return np.array([plotter.board.x, plotter.board.y], float) * plotter.board.unit


@pytest.mark.parametrize("profile", FAMILIES)
def test_the_pen_read_back_is_the_boards_own(profile, name):
    with open_control(f"sim://{name}", profile) as plotter:
        board = protocol_sim.plotter(name)
        before = plotter.pen_state()
        assert before == board_pen_down(board)
        after = plotter.pen("toggle")
        assert after is (not before) and board_pen_down(board) is after
        assert plotter.pen("toggle") is before and board_pen_down(board) is before
        assert plotter.pen("down") is True and board_pen_down(board)
        assert plotter.pen("cycle") is False and not board_pen_down(board)
        assert plotter.pen("up") is False


@pytest.mark.parametrize("profile", FAMILIES)
def test_walk_moves_the_carriage_and_home_brings_it_back(profile, name):
    with open_control(f"sim://{name}", profile) as plotter:
        board = protocol_sim.plotter(name)
        start = carriage_mm(board)
        where = plotter.walk(12.5, 7.25)
        assert np.allclose(carriage_mm(board) - start, (12.5, 7.25), atol=0.03)
        assert np.allclose(where, carriage_mm(board), atol=0.03)
        plotter.walk(-2.5, 0.0)
        assert np.allclose(carriage_mm(board) - start, (10.0, 7.25), atol=0.03)
        plotter.pen("down")
        assert np.allclose(plotter.home(), start, atol=0.03)
        assert np.allclose(carriage_mm(board), start, atol=0.03) and not board_pen_down(board)


def test_ebb_motors_off_frees_both_motors_and_on_holds_them(name):
    with open_control(f"sim://{name}", "axidraw-v3") as plotter:
        board = protocol_sim.plotter(name).firmware
        plotter.walk(5, 5)
        assert board.enabled == (16, 16)
        said = plotter.motors(False)
        assert board.enabled == (0, 0) and "EM,0,0" in said
        plotter.motors(True)
        assert board.enabled == (16, 16)


def test_an_ebb_walk_off_the_bed_is_refused_and_nothing_moves(name):
    with open_control(f"sim://{name}", "axidraw-v3") as plotter:
        board = protocol_sim.plotter(name)
        plotter.walk(10, 10)
        before = carriage_mm(board)
        with pytest.raises(PlotError, match="would leave the 300 x 218 mm bed; nothing moved"):
            plotter.walk(-20, 0)
        assert np.allclose(carriage_mm(board), before)


@pytest.mark.parametrize("profile", ["grbl-servo-a4", "grblhal-servo-a3"])
def test_grbl_motors_off_sets_an_idle_delay_and_on_holds_them(profile, name):
    with open_control(f"sim://{name}", profile) as plotter:
        machine = protocol_sim.plotter(name).machine
        assert "holds them at rest ($1=255" in plotter.motors(True)
        assert machine.settings[1] == 255
        start = carriage_mm(protocol_sim.plotter(name))
        said = plotter.motors(False)
        assert machine.settings[1] == 25 and "was 255" in said
        assert np.allclose(carriage_mm(protocol_sim.plotter(name)), start, atol=1e-9)  # the nudge goes back


def test_hpgl_has_no_motors_command_nor_pen_heights(name):
    with open_control(f"sim://{name}", "hp7475a") as plotter:
        with pytest.raises(PlotError, match="no command that switches its motors off"):
            plotter.motors(False)
        with pytest.raises(PlotError, match="solenoid"):
            plotter.try_height("down", 40)


def test_hpgl_walk_past_the_hard_clip_limits_is_refused(name):
    with open_control(f"sim://{name}", "hp7475a") as plotter:
        with pytest.raises(PlotError, match="past its hard-clip limits"):
            plotter.walk(-5, 0)
        unit = plotter.profile.paper.unit_mm  # a walk lands on the plotter's own unit
        assert plotter.walk(3, 4) == pytest.approx((3.0, 4.0), abs=unit / 2)


@pytest.mark.parametrize("height", [20.0, 45.0])
def test_an_ebb_height_trial_moves_the_servo_to_that_height(height, name):
    with open_control(f"sim://{name}", "axidraw-v3") as plotter:
        board = protocol_sim.plotter(name).firmware
        assert plotter.try_height("down", height) is True
        assert board.servos.target == pytest.approx(plotter.profile.ebb.servo_position(height))
        assert plotter.try_height("up", 70.0) is False
        assert board.servos.target == pytest.approx(plotter.profile.ebb.servo_position(70.0))


def test_a_grbl_height_trial_sends_the_height_the_machine_then_reports(name):
    with open_control(f"sim://{name}", "grbl-servo-a4") as plotter:
        machine = protocol_sim.plotter(name).machine
        plotter.try_height("down", 75)
        assert machine.state.spindle_speed == 75 and machine.pen_down


def test_a_trial_height_the_profile_rules_refuse_is_one_line(name):
    with (
        open_control(f"sim://{name}", "axidraw-v3") as plotter,
        pytest.raises(PencilbotError, match=r"pen down height: \[pen\] up = 60 is invalid"),
    ):
        plotter.try_height("down", 60)


def test_the_ebb_nickname_is_read_with_qt(name):
    from pencilbot.driver.ebb.names import find_named, nickname

    with open_control(f"sim://{name}", "axidraw-v3"):
        board = protocol_sim.plotter(name).firmware
    assert nickname(f"sim://{name}") == ""
    board.queries.nickname = "East EBB"
    assert nickname(f"sim://{name}") == "East EBB"
    assert find_named("East EBB", [f"sim://{name}"]) == f"sim://{name}"
    assert find_named("West EBB", [f"sim://{name}"]) is None


def test_the_library_api_opens_the_same_control(name):
    import pencilbot

    with pencilbot.open_control(f"sim://{name}", "axidraw-v3") as plotter:
        assert plotter.pen("down") is True and not protocol_sim.plotter(name).firmware.pen_up


@pytest.mark.parametrize("profile,board", [("axidraw-v3", "hp7475a"), ("hp7475a", "grbl-servo-a4")])
def test_the_wrong_board_is_one_line_naming_what_was_expected(profile, board, name):
    with pytest.raises(PlotError, match="no answer from an? (EBB board|HP-GL plotter)"):
        open_control(f"sim://{name}?profile={board}", profile, timeout=0.5)


@pytest.mark.parametrize("profile", ["axidraw-v3", "nextdraw-8511"])
def test_the_pen_command_moves_the_servo_on_the_profiles_own_pin(profile, name):
    """The NextDraw 8511's narrow-band servo is on RB2: an ``SP`` without its pin word moves RB1's
    pulses and leaves the pen where it was."""
    with open_control(f"sim://{name}", profile) as plotter:
        board = protocol_sim.plotter(name).firmware
        setup, pen = plotter.profile.ebb, plotter.profile.pen
        plotter.pen("down")
        assert board.servos.target == pytest.approx(setup.servo_position(pen.down))
        plotter.pen("up")
        assert board.servos.target == pytest.approx(setup.servo_position(pen.up))
