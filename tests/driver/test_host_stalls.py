"""A host that stalls (a loaded machine, a suspended process) is not a silent board: the driver
counts as silence only the time it spent listening, so a stall between reads or inside one
(a read counts at most its own timeout), however long, never stops a plot with "the plotter
stopped answering" — and a board that really is silent is still caught.

The stalls are made on the driver's own clock (no test waits on the wall clock for them): after
every read (or while one waits), the clock the driver reads jumps STALL seconds, as if the
process had been descheduled that long.
"""

from __future__ import annotations

import itertools
import os
import time

import pytest
import serial
from real_plan import plan_lines
from segments import drawing_differences

import sim
from pencilbot.driver import draw, port
from pencilbot.driver.ebb import link as ebb_link
from pencilbot.driver.gcode import session
from pencilbot.driver.hpgl import link as polled_link
from pencilbot.errors import PlotError
from sim import protocol_sim

STALL = 30.0  # s the host is away after each read: far past any timeout below
_names = itertools.count()


class StalledClock:
    """``time`` as the driver's modules see it: the real clock plus the stalls so far."""

    def __init__(self):
        self.away = 0.0

    def monotonic(self) -> float:
        return time.monotonic() + self.away

    def __getattr__(self, name):
        return getattr(time, name)


@pytest.fixture
def stalls(monkeypatch):
    clock = StalledClock()
    for module in (port, session, ebb_link, polled_link):  # the modules that read the clock
        monkeypatch.setattr(module, "time", clock)
    read_lines, pump = port.LineReader.read_lines, polled_link.Answers.pump

    def read_then_stall(self):
        lines = read_lines(self)
        clock.away += STALL
        return lines

    def pump_then_stall(self):  # the HP-GL driver's reads
        pump(self)
        clock.away += STALL

    monkeypatch.setattr(port.LineReader, "read_lines", read_then_stall)
    monkeypatch.setattr(polled_link.Answers, "pump", pump_then_stall)
    sim.register()
    return clock


def _drawn(name: str, ebb: bool):
    plotter = protocol_sim.plotter(name)
    plotter.firmware.finish()
    strokes = (
        list(plotter.drawn()) if ebb or not hasattr(plotter, "machine") else list(plotter.machine.strokes)
    )
    protocol_sim.forget(name)
    return strokes


BOARDS = [("grbl-servo-a4", "tick=0.01"), ("axidraw-v3", ""), ("hp7475a", "tick=0.1")]


def _job(profile: str, tmp_path) -> list[str] | str:
    """The first 400 lines of the real plan's G-code, or for the HP-GL plotter 150 small
    squares' outlines (more than its 1024-byte buffer holds)."""
    if profile != "hp7475a":
        return list(plan_lines(profile))[:400]
    program = ["IN;", "SP1;"]
    for k in range(150):
        x, y = 1000 + (k % 15) * 400, 1000 + (k // 15) * 400
        program.append(f"PU{x},{y};PD{x + 300},{y},{x + 300},{y + 300},{x},{y + 300},{x},{y};")
    path = tmp_path / "squares.hpgl"
    path.write_text("\n".join([*program, "PU0,0;", "SP0;"]) + "\n")
    return str(path)


def _silent_after(name: str, options: str, instructions: int) -> None:
    """An HP-GL plotter (``sim://NAME``) that answers nothing once it has run ``instructions``
    (its ``silent`` fault loses one answer only)."""
    import serial

    serial.serial_for_url(f"sim://{name}?profile=hp7475a&{options}").close()
    board = protocol_sim.plotter(name).board
    answer = board._answer  # noqa: SLF001 - the plotter's one way out

    def answer_until(text):
        if board.executed < instructions:
            answer(text)

    board._answer = answer_until  # noqa: SLF001


@pytest.mark.parametrize("profile, options", BOARDS)
def test_a_stalled_host_finishes_the_plot(stalls, profile, options, tmp_path):
    lines = _job(profile, tmp_path)
    ebb = profile == "axidraw-v3"
    reference = f"stall-ref{next(_names)}"
    draw(lines, f"sim://{reference}?profile={profile}&{options}", profile=profile)
    stalls.away = 0.0
    name = f"stall{next(_names)}"
    draw(lines, f"sim://{name}?profile={profile}&{options}", profile=profile, timeout=2.0)
    assert stalls.away > 10 * STALL  # the host was away far longer than the timeout, many times
    assert drawing_differences(_drawn(name, ebb), _drawn(reference, ebb), 0.001) == []


@pytest.mark.parametrize("profile, options", BOARDS)
def test_a_silent_board_is_still_caught(stalls, profile, options, tmp_path):
    name = f"stall{next(_names)}"
    faults = "&faults=silent@60"
    if profile == "hp7475a":
        _silent_after(name, options, 60)
        faults = ""
    with pytest.raises(PlotError, match="stopped answering|did not answer"):
        draw(
            _job(profile, tmp_path),
            f"sim://{name}?profile={profile}&{options}{faults}",
            profile=profile,
            timeout=1.0,
        )
    protocol_sim.forget(name)


def test_a_stalled_host_wakes_a_board_whose_banner_takes_several_reads(stalls):
    # At 9600 baud the board's start-up banner and its answers take some reads to come: a wait
    # for them that counted the host's stalls would give up ("no answer from a GRBL board").
    name = f"stall{next(_names)}"
    lines = ["G21", "G90", "G0X5Y5", "G0X0Y0"]
    draw(lines, f"sim://{name}?baud=9600&tick=0.01", profile="grbl-servo-a4", timeout=2.0)
    assert [line for line in protocol_sim.plotter(name).firmware.accepted_lines() if line] == lines
    protocol_sim.forget(name)


def test_a_read_that_finds_nothing_counts_at_most_its_own_timeout_as_silence(monkeypatch):
    # A pty nobody writes to: each read waits its 20 ms timeout, and the host is away for STALL
    # seconds inside it (descheduled between the select and the clock's reading).
    clock = StalledClock()
    for module in (port, polled_link):
        monkeypatch.setattr(module, "time", clock)
    master, slave = os.openpty()
    with serial.Serial(os.ttyname(slave), timeout=0.02) as device:
        read = device.read

        def read_in_a_stall(size=1):
            data = read(size)
            clock.away += STALL
            return data

        device.read = read_in_a_stall
        reader, answers = port.LineReader(device), polled_link.Answers(device)
        for _ in range(3):
            assert reader.read_lines() == []
            answers.pump()
        assert 0 < reader.silent_for() <= 3 * 0.02 and 0 < answers.listened <= 3 * 0.02
    os.close(master)
    os.close(slave)


def test_a_stalled_host_stops_on_a_signal_with_the_pen_s_place_proven(stalls, tmp_path):
    # The stop's feed hold waits for the machine to come to rest; that wait counts time spent
    # listening, so the stalls do not cut it short (a stop not known to be at rest cannot prove
    # where the pen stopped, and the resume would ask for a re-zero).
    lines = list(plan_lines("grbl-servo-a4"))[:400]
    reference = f"stall-ref{next(_names)}"
    draw(lines, f"sim://{reference}?tick=0.01", profile="grbl-servo-a4")
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(lines) + "\n")
    name = f"stall{next(_names)}"
    with pytest.raises(PlotError, match="stopped by Ctrl-C") as stop:
        draw(path, f"sim://{name}?tick=0.01&faults=interrupt@200", profile="grbl-servo-a4", timeout=2.0)
    assert "cannot prove" not in str(stop.value)
    protocol_sim.plotter(name).firmware.faults.at.clear()
    draw(path, f"sim://{name}", resume=f"{path}.job.json", timeout=2.0)  # nobody asked to re-zero
    assert drawing_differences(_drawn(name, False), _drawn(reference, False), 0.001) == []


def test_a_stalled_host_still_finds_what_a_port_is(stalls, monkeypatch):
    # `pencilbot ports` listens for a banner and for the answers to its questions; a board at 9600
    # baud takes some reads to say it, and the stalls between them are not the board's silence.
    from pencilbot.driver import ports

    monkeypatch.setattr(ports, "time", stalls)
    read = ports._Lines._read  # noqa: SLF001

    def read_then_stall(self):
        came = read(self)
        stalls.away += STALL
        return came

    monkeypatch.setattr(ports._Lines, "_read", read_then_stall)  # noqa: SLF001
    found = ports.probe("sim://?baud=9600")
    assert (found.plotter, found.version) == ("GRBL", "1.1h"), found
