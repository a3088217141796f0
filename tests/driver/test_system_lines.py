"""The ``$`` lines of a G-code file (issue 33): a jog is a move the bed check follows, every other
system command is refused by line before the port is opened unless it is named with
``--allow-system-commands``, and then what it does is said (check mode: nothing after it is
drawn; sleep must be the last line and ends the job instead of hanging)."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_stream_sim import PROFILE, fresh

from pencilbot.cli import main
from pencilbot.driver.gcode.bed_check import check_on_bed
from pencilbot.driver.gcode.job import load_job
from pencilbot.driver.gcode.system_lines import allowed_names
from pencilbot.errors import OutOfBedError, PencilbotError
from pencilbot.firmware.grbl_system import command_name
from pencilbot.machine.profile import load_profile
from sim import protocol_sim

GRBL = load_profile(PROFILE)  # bed X 0 .. 220, Y 0 .. 310 mm


def run_cli(capsys, tmp_path, command, lines, *extra):
    path = tmp_path / "job.gcode"
    path.write_text("\n".join(lines) + "\n")
    if command == "draw":
        url, name = fresh()
        argv = ["draw", str(path), "--port", url, "--profile", PROFILE, "-q", *extra]
    elif command == "simulate":
        name = None
        argv = ["simulate", str(path), "-o", str(tmp_path / "out.png"), "--profile", PROFILE, "-q", *extra]
    else:
        name = None
        argv = ["stat", str(path), "--profile", PROFILE, *extra]
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.err, name, path


@pytest.mark.parametrize(
    "jog, where",
    [
        ("$J=G53 X900 Y900 F3000", "X 900.000 Y 900.000"),
        ("$J=G91 X500 F3000", "X 510.000 Y 10.000"),
        ("$J=G20 X10 Y1 F100", "X 254.000 Y 25.400"),
    ],
)
def test_a_jog_off_the_bed_is_refused_by_line_and_nothing_is_sent(capsys, tmp_path, jog, where):
    lines = ["G21", "G90", "G0 X10 Y10", jog, "G0 X20 Y20"]
    code, err, name, path = run_cli(capsys, tmp_path, "draw", lines)
    assert code == 2 and err.startswith(
        f"pencilbot: error: line 4 of {path} ({jog.replace(' ', '')!r}) moves to {where} mm, off the bed"
    ), err
    assert err.count("\n") == 1 and name not in protocol_sim._PLOTTERS


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(-50, 300),
    y=st.floats(-50, 400),
    relative=st.booleans(),
    machine=st.booleans(),
    inches=st.booleans(),
)
def test_the_bed_check_follows_a_jog_as_grbl_moves_it_and_the_job_modes_stay(x, y, relative, machine, inches):
    modes = ("G53" if machine else "G91" if relative else "G90") + ("G20" if inches else "")
    before = (10.0, 20.0)
    job = load_job(["G21", "G90", "G0 X10 Y20", f"$J={modes} X{x:.3f} Y{y:.3f} F500", "G1 X1 F100"], GRBL)
    scale = 25.4 if inches else 1.0
    target = np.array([round(x, 3), round(y, 3)]) * scale + (before if relative and not machine else 0.0)
    on_bed = 0 <= target[0] <= 220 and 0 <= target[1] <= 310
    if on_bed:
        check_on_bed(job)
    else:
        with pytest.raises(OutOfBedError, match="line 4 of"):
            check_on_bed(job)
    jogged, after = job.state_after(3), job.state_after(4)
    assert np.allclose(jogged.position_mm()[:2], target, atol=1e-6)
    # The jog's own G91 / G20 / F last for its line only, as in GRBL: the next line is a G90 mm move.
    assert not after.relative and not after.inches and after.feed == 100.0
    assert np.allclose(after.position_mm()[:2], [1.0, target[1]], atol=1e-6)


@pytest.mark.parametrize(
    "line, name",
    [
        ("$N0=G0X5", "$N0"),
        ("$100=250", "$100"),
        ("$3=1", "$3"),
        ("$130=10", "$130"),
        ("$SLP", "$SLP"),
        ("$C", "$C"),
        ("$RST=*", "$RST"),
        ("$H", "$H"),
        ("$X", "$X"),
        ("$$", "$$"),
        ("$#", "$#"),
    ],
)
@pytest.mark.parametrize("command", ["draw", "simulate", "stat"])
def test_a_system_command_is_refused_by_line_unless_named(capsys, tmp_path, command, line, name):
    lines = ["G21", "G90", "M3 S30", line, "M3 S90", "G1 X10 Y10 F1000", "M3 S30"]
    code, err, plotter, path = run_cli(capsys, tmp_path, command, lines)
    assert code == 2 and err.startswith(
        f"pencilbot: error: line 4 of {path} ({line!r}) is a system command"
    ), err
    assert f"--allow-system-commands '{name}'" in err and err.count("\n") == 1
    assert plotter not in protocol_sim._PLOTTERS and not (tmp_path / "out.png").exists()


def test_check_mode_when_allowed_is_said_and_draws_nothing_after_it(capsys, caplog, tmp_path):
    lines = ["G21", "M3 S90", "G1 X5 F1000", "M3 S30", "$C", "M3 S90", "G1 X10 Y10 F1000", "G1 X20", "M3 S30"]
    job = load_job(lines, GRBL, allow=allowed_names("$C"))
    assert job.system.check_from == 4 and "nothing after it is drawn" in job.system.notes[0]
    path = tmp_path / "job.gcode"
    path.write_text("\n".join(lines) + "\n")
    code = main(["stat", str(path), "--profile", PROFILE, "--allow-system-commands", "$C", "--json"])
    assert code == 0 and "check mode" in caplog.text
    assert json.loads(capsys.readouterr().out)["total"]["pen_down_mm"] == pytest.approx(
        5.0
    )  # the X5 before $C only
    only_check = ["G21", "$C", "M3 S90", "G1 X10 Y10 F1000", "M3 S30"]
    code, err, _, path = run_cli(capsys, tmp_path, "stat", only_check, "--allow-system-commands", "C")
    assert code == 2 and err.startswith(f"pencilbot: error: {path} draws nothing: line 2"), err
    with pytest.raises(PencilbotError, match="leaves check mode"):
        load_job(["G21", "$C", "G0 X1", "$C", "G0 X2"], GRBL, allow=allowed_names("$C"))


def test_sleep_when_allowed_must_be_last_and_ends_the_job(capsys, caplog, tmp_path):
    with pytest.raises(PencilbotError, match="1 command lines come after it"):
        load_job(["G21", "$SLP", "G0 X1"], GRBL, allow=allowed_names("$SLP"))
    lines = ["G21", "M3 S90", "G1 X10 Y10 F1000", "M3 S30", "$SLP"]
    # Asleep, the board answers status reports and nothing else: the job is over, not waiting.
    code, err, name, _ = run_cli(
        capsys, tmp_path, "draw", lines, "--allow-system-commands", "$SLP", "--timeout", "5"
    )
    assert code == 0 and "puts the board to sleep" in caplog.text, err
    assert len(protocol_sim.plotter(name).machine.drawn()) == 1


def test_names_are_read_as_a_person_writes_them():
    assert allowed_names("$H,$C") == {"$H", "$C"}
    assert allowed_names("h c $100= $n0") == {"$H", "$C", "$100", "$N0"}
    assert (
        command_name("$RST=*") == "$RST" and command_name("$J=G91X1F1") is None and command_name("$$") == "$$"
    )
    assert command_name("$N0=G0X5") == "$N0" and command_name("G0X1") is None


def test_a_jog_on_the_bed_is_drawn_around_as_grbl_runs_it(capsys, tmp_path):
    # GRBL refuses G-code while it jogs (error:9): the sender waits the jog out, then goes on
    # from where it ended.
    lines = [
        "G21",
        "G90",
        "M3 S30",
        "G0 X10 Y10",
        "$J=G91 X30 Y5 F3000",
        "M3 S90",
        "G91 G1 X10 F1000",
        "M3 S30",
    ]
    code, err, name, _ = run_cli(capsys, tmp_path, "draw", lines)
    assert code == 0, err
    (stroke,) = protocol_sim.plotter(name).machine.drawn()
    assert np.allclose(np.asarray(stroke)[[0, -1], :2], [[40, 15], [50, 15]], atol=1e-3)
