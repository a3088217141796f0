"""The virtual plotter's fast path (sim.bulk) against the full interpreter, line by line.

The reference is the GRBL front end itself: every line of the file through
``Firmware.receive`` (filter, parser, execution, planner, recorder). The fast path must leave
the machine with the same strokes, travel, clock and position, bit for bit, and stop at the
line where the board first answers anything but ``ok`` (an error, an alarm), or at the first
line it does not take. ``pencilbot simulate`` through either way gives the same PNG and words.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pencilbot.cli import main
from pencilbot.commands import simulate as simulate_command
from sim import bulk, bulk_timing, protocol_sim

PROFILE = "grbl-servo-a4"  # a servo pen on the spindle: M3 S30 up, M3 S90 down; bed 220 x 310 mm
#: The two pens the fast path plays; a Z pen (up 4 mm, down 0) on a bed whose origin is top-right
#: (machine X and Y run negative): every X and Y is this sign times a distance from the origin.
SIGNS = {"grbl-servo-a4": 1, "grbl-z-a3": -1}


def _plotter(profile: str = PROFILE):
    return protocol_sim.plotter_from_options({"profile": profile, "realtime": "0", "limits": "bed"})


def _full(text: bytes, profile: str = PROFILE):
    """The machine after each line through the firmware, and the first line not answered ok."""
    plotter = _plotter(profile)
    for line in text.splitlines(keepends=True):
        plotter.firmware.receive(line)
    plotter.firmware.finish()
    refused = next(((e.index, e.reply) for e in plotter.firmware.log if e.reply != "ok"), None)
    return plotter.machine, refused


def _fast(text: bytes, block_lines: int, profile: str = PROFILE):
    """The machine after the fast path, fed ``block_lines`` lines at a time (block edges vary)."""
    plotter = _plotter(profile)
    assert bulk.fast_path_possible(plotter.machine)
    lines = text.splitlines(keepends=True)
    blocks = [b"".join(lines[i : i + block_lines]) for i in range(0, len(lines), block_lines)]
    stop = bulk.run_blocks(plotter.machine, blocks)
    plotter.firmware.finish()
    return plotter.machine, stop


def _same_machine(fast, full) -> None:
    a, b = fast.drawn(), full.drawn()
    assert np.array_equal(a.points, b.points) and np.array_equal(a.offsets, b.offsets)
    ta, tb = fast.bed_travel(), full.bed_travel()
    assert np.array_equal(ta.points, tb.points) and np.array_equal(ta.offsets, tb.offsets)
    assert fast.stroke_pauses == full.stroke_pauses
    assert fast.clock == full.clock  # the same additions in the same order: equal, not close
    assert fast.state.position == full.state.position


_coord = st.integers(0, 200_000).map(lambda v: v / 1000)  # 0 .. 200 mm in µm, inside the bed
#: Pen lines by profile: what lifts and lowers it, and what does not (M3 for a Z pen, Z for a servo).
_PENS = {
    1: ["M3 S30", "M3 S90", "M3 S90", "M5", "M3", "M4 S90", "S", "G0 Z4"],
    -1: ["G0 Z0", "G0 Z4.0", "G1 Z1.9", "G1 Z2.1", "G0 Z0", "M3 S90", "M5"],
}


@st.composite
def plain_lines(draw, sign: int = 1) -> list[str]:
    """A job of the plain forms: pen changes, dwells, moves alone and runs of moves (longer than
    the planner), modal moves, zero-length moves, feeds, comments, blank lines, lower case."""
    lines = ["G21 ; mm", "G90", "G94", "g17"]
    if draw(st.integers(0, 3)):  # mostly a feed first (else a G1 before any F is refused: error 22)
        lines.append(draw(st.sampled_from(["F3000", "G1 F1500", "G0 F600"])))
    x = y = 0.0
    for _ in range(draw(st.integers(3, 14))):
        kind = draw(st.sampled_from(["pen", "pen", "dwell", "move", "run", "run", "blank", "feed"]))
        if kind == "pen":
            pen = draw(st.sampled_from(_PENS[sign]))
            lines.append(pen if pen != "S" else "M3 S" + str(draw(st.integers(0, 120))))
        elif kind == "dwell":
            lines.append(f"G4 P{draw(st.sampled_from(['0', '0.15', '0.2', '1.5']))}")
        elif kind == "blank":
            lines.append(draw(st.sampled_from(["", "; a comment", "   "])))
        elif kind == "feed":
            lines.append(f"F{draw(st.sampled_from(['500', '3000', '12000']))}")
        else:
            for _ in range(1 if kind == "move" else draw(st.integers(2, 40))):
                g = draw(st.sampled_from(["G0 ", "G1 ", "g1", "G01 ", ""]))
                same = draw(st.integers(0, 9)) == 0
                nx, ny = (x, y) if same else (draw(_coord), draw(_coord))
                words = draw(st.sampled_from(["XY", "X", "Y", "XYZ"]))
                z = draw(st.sampled_from([0.0, 4.0]))
                text = g + " ".join(
                    f"{a}{v:g}" for a, v in (("X", sign * nx), ("Y", sign * ny), ("Z", z)) if a in words
                )
                if words == "X":
                    ny = y
                if words == "Y":
                    nx = x
                x, y = nx, ny
                if draw(st.integers(0, 3)) == 0:
                    text += f" F{draw(st.sampled_from(['800', '3000', '20000']))}"
                lines.append(text)
    return lines


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data(), profile=st.sampled_from(sorted(SIGNS)), block_lines=st.integers(1, 50))
def test_fast_path_leaves_the_machine_as_the_full_interpreter(data, profile, block_lines):
    lines = data.draw(plain_lines(SIGNS[profile]))
    text = ("\n".join(lines) + "\n").encode()
    full, refused = _full(text, profile)
    fast, stop = _fast(text, block_lines, profile)
    if refused is None:
        assert stop is None
        _same_machine(fast, full)
    else:  # only a G1 before any feed is refused here: the fast path stops at that very line
        assert stop == bulk.Stop(refused[0], refused[1])


@st.composite
def dense_runs(draw, sign: int = 1) -> list[str]:
    """Runs of many short moves (most shorter than the distance the machine needs to stop from
    its top speed, so how far the planner looks ahead decides their speeds; a run longer than the
    planner; straight on, curving or turning back), between pen changes and dwells."""
    down, up = ("M3 S90", "M3 S30") if sign == 1 else ("G0 Z0", "G0 Z4")
    lines = ["G21", "G90", f"F{draw(st.sampled_from(['600', '3000', '20000']))}"]
    x, y, heading = 100.0, 150.0, 0.0
    for _ in range(draw(st.integers(1, 4))):
        lines += [down, *draw(st.sampled_from([[], ["G4 P0.2"]]))]
        # Each run its own kind of line: straight, a gentle curve, or turning anywhere.
        turns = draw(st.sampled_from([[0], [0, 1, 2], [0, 1, -1, 8, -30, 90, 179]]))
        steps = draw(st.sampled_from([[0.1], [0.02, 0.3], [0.001, 0.02, 0.1, 0.7, 3.0]]))
        for _ in range(draw(st.integers(1, 90))):
            heading += draw(st.sampled_from(turns))
            step = draw(st.sampled_from(steps))
            x = min(max(x + step * math.cos(math.radians(heading)), 1.0), 200.0)
            y = min(max(y + step * math.sin(math.radians(heading)), 1.0), 280.0)
            g = draw(st.sampled_from(["G1 ", "G1 ", "", "G0 "]))
            lines.append(f"{g}X{sign * x:.3f} Y{sign * y:.3f}" + draw(st.sampled_from(["", "", " F9000"])))
        lines += [up, *draw(st.sampled_from([[], ["G4 P0.15"], ["M5"]]))]
    return lines


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    data=st.data(),
    profile=st.sampled_from(sorted(SIGNS)),
    block_lines=st.integers(1, 80),
    sweeps=st.sampled_from([bulk_timing.SWEEPS, 1]),
)
def test_fast_path_times_long_runs_of_short_moves_as_the_planner(data, profile, block_lines, sweeps):
    """The look-ahead decides these moves' speeds: the fast path's clock is still the planner's
    to the bit, whatever the block edges, and when its sweeps leave moves to do one by one."""
    text = ("\n".join(data.draw(dense_runs(SIGNS[profile]))) + "\n").encode()
    full, refused = _full(text, profile)
    before, bulk_timing.SWEEPS = bulk_timing.SWEEPS, sweeps
    try:
        fast, stop = _fast(text, block_lines, profile)
    finally:
        bulk_timing.SWEEPS = before
    assert refused is None and stop is None
    _same_machine(fast, full)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    lines=plain_lines(),
    at=st.integers(0, 10_000),
    bad=st.sampled_from(
        [
            ("G1 X10 Y10", "error:22"),  # a feed move before any F
            ("G0 X230 Y10", "ALARM:2"),  # past the bed's 220 mm: the soft limit
            ("G1 X-5 F3000", "ALARM:2"),
            ("G0 Y310.5", "ALARM:2"),
        ]
    ),
)
def test_fast_path_stops_where_the_board_refuses(lines, at, bad):
    at = at % (len(lines) + 1)
    line, answer = bad
    if answer == "error:22":
        lines = [text for text in lines if "F" not in text.upper()]  # no feed yet anywhere
    else:
        lines = ["F3000", *lines]  # no G1 is refused before
    lines = lines[:at] + [line] + lines[at:]
    text = ("\n".join(lines) + "\n").encode()
    _, refused = _full(text)
    _, stop = _fast(text, 7)
    assert refused is not None and refused[1] == answer  # the board's own answer
    assert stop == bulk.Stop(refused[0], answer)  # at the same line


_GOOD = ["10", "+20", "-0", "0", "7.5", ".5", "5.", "120.25", "1.2345678", "007"]
_ODD = ["1.2.3", "", "-", "1-2", "5+", "123456789", "-3", "1e2", "0x1"]
_CODES = ["G0", "G1", "g01", "G00", "G4", "G04", "G21", "G90", "G94", "G17", "G2", "G10", "G1.0", "G001",
          "G91", "M3", "M03", "M4", "M5", "M05", "M0", "M30", "M2", "N5", "T1", "E5", "X", "Y", "Z", "F", "S", "P"]  # fmt: skip
_TEMPLATES = ["G1 X# Y#", "G0 X#", "X# Y# Z# F@", "G1 Y# F@", "M3 S@", "M5", "M4", "G4 P@", "G21", "F@", "Z#"]


@st.composite
def word_soup(draw) -> list[str]:
    """Plain lines and one near miss among them: a word a board reads otherwise or not at all, a
    number of another form, words swapped or repeated; spaces, tabs, case and comments anywhere."""
    lines = ["F3000", "M3 S90"]
    odd = draw(st.integers(2, 13))
    for index in range(2, draw(st.integers(odd, 14)) + 1):
        words = draw(st.sampled_from(_TEMPLATES)).split()
        # (a sign on F, S or P is a line of another form, whatever the board makes of it)
        words = [
            w.replace("#", draw(st.sampled_from(_GOOD))).replace("@", draw(st.sampled_from(_GOOD[4:])))
            for w in words
        ]
        at = draw(st.integers(0, len(words) - 1))
        change = draw(st.sampled_from(["word", "number", "swap", "repeat"])) if index == odd else ""
        if change == "word":
            code = draw(st.sampled_from(_CODES))
            words.insert(at, code + (draw(st.sampled_from(_GOOD + _ODD)) if code[-1].isalpha() else ""))
        elif change == "number" and len(words[at]) > 1 and words[at][0] not in "GM":
            words[at] = words[at][0] + draw(st.sampled_from(_ODD))
        elif change == "swap":
            words[at], words[-1] = words[-1], words[at]
        elif change == "repeat":
            words.insert(at, words[at])
        if draw(st.booleans()):
            words = [w.lower() for w in words]
        line = draw(st.sampled_from([" ", "", "\t"])).join(words)
        lines.append(line + draw(st.sampled_from(["", "", " ; note", ";"])))
    return lines


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(lines=word_soup(), block_lines=st.integers(1, 5))
def test_what_the_fast_path_reads_the_board_reads_the_same(lines, block_lines):
    """A line the fast path takes means what it means to the board; it stops at a refusal the
    board makes there, and at a line of another form before any refusal."""
    text = ("\n".join(lines) + "\n").encode()
    full, refused = _full(text)
    fast, stop = _fast(text, block_lines)
    if stop is None:
        assert refused is None
        _same_machine(fast, full)
    elif stop.reason == "unsupported":
        assert refused is None or refused[0] >= stop.line
    else:
        assert refused == (stop.line, stop.reason)


@pytest.mark.parametrize(
    "other",
    [
        "G2 X10 Y0 I5 J0 F100",
        "G91",
        "M0",
        "$H",
        "G92 X0",
        "(note) G0 X1",
        "%",
        "G1 X1.234567891 F100",
        "G1 X123456789 F100",
        "G0 X1 X2",
        "G0 X1\rG0 X2",
        "G2 X10 Y0",  # an arc needs its centre
        "G1 F-3",  # no sign on F, S, P
        "M3 S-5",
        "G4 P+1",
        "G4",  # a dwell needs its P
        "G1 X1-2",  # a sign only first
        "G1 X5+",
        "G1 X.",
        "G1 X1.2.3",
        "G1 Y5 X3",  # words in another order than a plain line's
        "X5 G1",
        "M3 G1 X5",
        "G21 G90",
    ],
)
def test_fast_path_stops_at_a_line_of_another_form(other):
    text = f"G21\nG0 X10 Y10\n{other}\nG0 X20 Y20\n".encode()
    _, stop = _fast(text, 2)
    assert stop == bulk.Stop(3, "unsupported")


@pytest.mark.parametrize(
    "text",
    [
        b"G21\r\nM3 S90\r\nG1 X10 Y10 F3000\r\nG1 X20\r\nM3 S30\r\n",  # CRLF line ends
        b"F3000\nM3 S90\nG1 X1.2345678 Y012.34567\nG1 X+7.9999999 Y.12345678\nM5\n",  # 8 digits: read exactly
    ],
)
def test_fast_path_takes_what_the_board_reads_the_same(text):
    full, refused = _full(text)
    fast, stop = _fast(text, 2)
    assert refused is None and stop is None
    _same_machine(fast, full)


def test_an_empty_job_goes_the_full_way():
    _, stop = _fast(b"; nothing\n\n", 5)
    assert stop == bulk.Stop(0, "empty")


def _simulate(tmp_path, capsys, text: str, *options: str):
    src = tmp_path / "job.gcode"
    src.write_text(text)
    out = tmp_path / "plot.png"
    code = main(["simulate", str(src), "-o", str(out), "--dpi", "60", *options])
    said = capsys.readouterr()
    return (
        code,
        (out.read_bytes() if out.exists() else None),
        said.out,
        [line for line in said.err.splitlines() if line.startswith("pencilbot:")],
    )


JOB = """G21
G90
M3 S30
G0 X20 Y20
M3 S90
G4 P0.2
G1 X60 Y22 F3000
G1 X61 Y60
G1 X20 Y58
G1 X20 Y20
M3 S30
G0 X100 Y100
M3 S90
G1 X120 Y140
M3 S30
G0 X0 Y0
"""


@pytest.mark.parametrize(
    "job", [JOB, JOB.replace("G1 X120 Y140", "G1 X120 Y140\nG1 X300 Y10"), JOB.replace("F3000", "")]
)
def test_simulate_says_and_draws_the_same_either_way(tmp_path, capsys, monkeypatch, job):
    """The fast path's PNG and words are the full way's; a job it stops in (a move off the bed, a
    move without a feed) gets the full way's message naming the line."""
    fast = _simulate(tmp_path, capsys, job, "--travel")
    monkeypatch.setattr(simulate_command, "_fast_plot", lambda *args: None)
    full = _simulate(tmp_path, capsys, job, "--travel")
    assert fast == full
    if job != JOB:
        assert fast[0] != 0 and fast[3][0].startswith("pencilbot: error: ") and "line" in fast[3][0]
