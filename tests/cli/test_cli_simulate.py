"""`pencilbot simulate` and `pencilbot sim-serve` end to end: real files, real pty, real PNGs."""

import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import serial
from PIL import Image

from firmware_protocol import grbl
from pencilbot.cli import main

SQUARE = """G21
G90
M3 S30
G0 X20 Y20
M3 S90
G4 P0.2
G1 X60 F3000
G1 Y60
G1 X20
G1 Y20
M3 S30
G0 X0 Y0
"""
DPI = 100


def ink(png):
    return 1.0 - np.asarray(Image.open(png).convert("L"), dtype=np.float64) / 255.0


def px(rows, x, y, bed_height=310.0):
    """Pixel (row, col) of bed point (x, y) mm, Y up (``rows`` only checks the image is the bed)."""
    mm = DPI / 25.4
    assert abs(rows - bed_height * mm) <= 1
    return int((bed_height - y) * mm), int(x * mm)


def test_simulate_gcode_draws_the_square_and_reports_time(tmp_path, capsys):
    src = tmp_path / "square.gcode"
    src.write_text(SQUARE)
    out = tmp_path / "plot.png"
    assert main(["simulate", str(src), "-o", str(out), "--dpi", str(DPI), "-q"]) == 0
    dark = ink(out)
    rows = dark.shape[0]
    assert np.allclose(dark.shape, (310 / 25.4 * DPI, 220 / 25.4 * DPI), atol=1)  # the whole bed
    for x, y in [(40, 20), (60, 40), (40, 60), (20, 40)]:
        r, c = px(rows, x, y)
        assert dark[r - 1 : r + 2, c - 1 : c + 2].max() > 0.5
    r0, c0 = px(rows, 25, 55)
    r1, c1 = px(rows, 55, 25)
    assert dark[r0:r1, c0:c1].max() < 0.02
    assert capsys.readouterr().out == ""

    assert main(["simulate", str(src), "-o", str(out), "--dpi", str(DPI), "--travel"]) == 0
    said = capsys.readouterr().out
    assert "pen-down strokes" in said and "simulated drawing time 0:00:0" in said
    travel = np.asarray(Image.open(out).convert("RGB"), dtype=int)
    r, c = px(rows, 10, 10)  # on the pen-up diagonal from (0,0) to (20,20)
    red = travel[r - 2 : r + 3, c - 2 : c + 3]
    assert ((red[..., 0] - red[..., 2]) > 60).any()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["simulate", "{missing}", "-o", "{out}"], "no such file"),
        (["simulate", "{src}", "-o", "{tmp}/plot.jpg"], ".png"),
        (["simulate", "{src}", "-o", "{out}", "--profile", "marlin-servo-a4"], "GRBL"),
        (["simulate", "{src}", "-o", "{out}", "--profile", "nope"], "nope"),
        (["simulate", "{src}", "-o", "{out}", "--dpi", "0"], "--dpi"),
        # Without the bounds these grew to 22.5 GB, died in MemoryError / ZeroDivisionError, or hung.
        (["simulate", "{src}", "-o", "{out}", "--dpi", "5000"], "gigapixels pencilbot renders; use --dpi"),
        (
            ["simulate", "{src}", "-o", "{out}", "--dpi", "30000"],
            "--dpi must be at least 1 and at most 10000",
        ),
        (
            ["simulate", "{src}", "-o", "{out}", "--pen-width", "1e9"],
            "--pen-width must be at least 0.05 and at most 50 mm",
        ),
        (["simulate", "{src}", "-o", "{out}", "--dpi", "inf"], "--dpi must be at least 1"),
        (["simulate", "{src}", "-o", "{out}", "--realtime", "nan"], "--realtime must be at least 0"),
    ],
)
def test_simulate_bad_input_is_one_clear_error_and_no_file(tmp_path, capsys, argv, message):
    src = tmp_path / "square.gcode"
    src.write_text(SQUARE)
    out = tmp_path / "plot.png"
    values = {"missing": tmp_path / "none.gcode", "out": out, "src": src, "tmp": tmp_path}
    assert main([a.format(**values) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pencilbot: error:") and message in err and "Traceback" not in err
    assert not out.exists() and not (tmp_path / "plot.jpg").exists()


def test_simulate_gcode_outside_the_bed_fails_with_the_alarm(tmp_path, capsys):
    src = tmp_path / "far.gcode"
    src.write_text("G21\nG90\nG0 X500 Y10\n")
    out = tmp_path / "plot.png"
    assert main(["simulate", str(src), "-o", str(out), "-q"]) != 0
    err = capsys.readouterr().err
    assert err.startswith("pencilbot: error:") and "Traceback" not in err
    assert not out.exists()


def test_simulate_fault_names_the_file_and_line_not_a_library_call(tmp_path, capsys):
    src = tmp_path / "arc.gcode"
    src.write_text("G21\nG90\nG0 X10 Y10\nG2 X1\n")
    assert main(["simulate", str(src), "-o", str(tmp_path / "plot.png"), "-q"]) != 0
    err = capsys.readouterr().err
    # (The travel on line 3 ran: the resume starts at the refused line, sent again.)
    assert f"at line 4 of {src} ('G2X1')" in err and f"Resume from line 4 of {src}" in err
    assert "<lines>" not in err and "draw(" not in err and "--start-line" not in err


def test_simulate_takes_gcode_with_utf8_comments_as_draw_does(tmp_path, capsys):
    src = tmp_path / "caf\u00e9.gcode"
    src.write_text("; made by some tool \u2014 caf\u00e9\n" + SQUARE, encoding="utf-8")
    out = tmp_path / "plot.png"
    assert main(["simulate", str(src), "-o", str(out), "--dpi", str(DPI), "-q"]) == 0
    dark = ink(out)
    assert dark[px(dark.shape[0], 40, 20)] > 0.5  # on the square's bottom edge


def test_simulate_refuses_a_command_that_is_not_ascii_naming_the_line(tmp_path, capsys):
    src = tmp_path / "odd.gcode"
    src.write_text("G21\nG90\nG0 X1\u00b2 Y1\n", encoding="utf-8")
    assert main(["simulate", str(src), "-o", str(tmp_path / "plot.png"), "-q"]) != 0
    err = capsys.readouterr().err
    assert f"line 3 of {src}" in err and "non-ASCII" in err and "Traceback" not in err


FOREIGN = """%
(a CAM program: arcs, inches, relative moves, a byte-order mark and % markers)
G21 G90 G17
G0 X60 Y60
M3 S90
G2 X60 Y60 I0 J-25 F2000
M3 S30
G0 X140 Y150
M3 S90
G91 G1 X20
G3 X0 Y20 R-10
G90 M3 S30
G20 G0 X1 Y10
M3 S90
G2 X3 Y10 I1 J0 F80
M3 S30
M2
%
"""


def test_simulate_foreign_gcode_draws_the_picture_it_describes(tmp_path):
    src = tmp_path / "foreign.nc"
    src.write_bytes(b"\xef\xbb\xbf" + FOREIGN.encode("ascii"))
    out = tmp_path / "plot.png"
    assert main(["simulate", str(src), "-o", str(out), "--dpi", str(DPI), "-q"]) == 0
    dark = ink(out)
    rows = dark.shape[0]

    def inked(x, y):
        r, c = px(rows, x, y)
        return dark[r - 1 : r + 2, c - 1 : c + 2].max()

    # the full circle: centre (60, 35), r = 25
    for angle in np.radians([0, 45, 90, 135, 180, 225, 270, 315]):
        assert inked(60 + 25 * np.cos(angle), 35 + 25 * np.sin(angle)) > 0.5
    assert inked(60, 35) < 0.02
    # relative line (140, 150) → (160, 150), then the half circle bulging right to x = 170
    assert inked(150, 150) > 0.5 and inked(170, 160) > 0.5 and inked(150, 160) < 0.02
    # the inch arc: centre (2, 10) in = (50.8, 254) mm, r = 25.4 mm, over the top
    assert inked(50.8, 279.4) > 0.5 and inked(50.8, 228.6) < 0.02


def test_simulate_a_photo(tmp_path):
    from skimage import data

    photo = tmp_path / "camera.png"
    Image.fromarray(data.camera()[::4, ::4]).save(photo)
    out = tmp_path / "plot.png"
    assert main(["simulate", str(photo), "-o", str(out), "--dpi", "50", "-q"]) == 0
    dark = ink(out)
    assert 0.01 < dark.mean() < 0.6  # a drawing: some graphite, mostly paper


def test_simulate_a_plan_svg_draws_its_paths(tmp_path):
    from pencilbot.export.svg import write_svg
    from pencilbot.planning.plan import Layer, Page, Plan

    plan = Plan(
        Page(210.0, 297.0, margin=15.0, name="A4"),
        [Layer("edges", [np.array([[50.0, 50.0], [150.0, 50.0], [150.0, 150.0]])], pen_width=0.5)],
    )
    svg = tmp_path / "plan.svg"
    write_svg(plan, svg)
    out = tmp_path / "plot.png"
    assert main(["simulate", str(svg), "-o", str(out), "--dpi", str(DPI), "-q"]) == 0
    dark = ink(out)
    # an L of 100 + 100 mm at 0.5 mm: about that much ink, wherever the writer placed the page
    inked_mm2 = dark.sum() / (DPI / 25.4) ** 2
    assert 0.7 * 200 * 0.5 < inked_mm2 < 1.3 * 200 * 0.5


def test_a_one_pen_g_code_file_is_simulated_with_the_pen_its_header_names(tmp_path):
    """The header records a one-pen plan's pen width, so `simulate` draws the exported file with
    it (it used to draw every such file at 0.5 mm)."""
    from pencilbot.export.gcode import header_pen_width, write_gcode
    from pencilbot.machine.profile import load_profile
    from pencilbot.planning.plan import Layer, Page, Plan

    plan = Plan(
        Page(210.0, 297.0, margin=15.0, name="A4"),
        [Layer("edges", [np.array([[50.0, 50.0], [150.0, 50.0], [150.0, 150.0]])], pen_width=1.2)],
    )
    gcode = tmp_path / "plan.gcode"
    write_gcode(plan, load_profile("grbl-servo-a4"), gcode)
    assert "; pen width: 1.2 mm\n" in gcode.read_text() and header_pen_width(gcode.read_bytes()) == 1.2
    plots = {}
    for name, extra in (("header", []), ("given", ["--pen-width", "1.2"]), ("thin", ["--pen-width", "0.5"])):
        plots[name] = tmp_path / f"{name}.png"
        assert main(["simulate", str(gcode), "-o", str(plots[name]), "--dpi", str(DPI), "-q", *extra]) == 0
    assert np.array_equal(ink(plots["header"]), ink(plots["given"]))
    inked_mm2 = ink(plots["header"]).sum() / (DPI / 25.4) ** 2
    assert (
        0.7 * 200 * 1.2 < inked_mm2 < 1.3 * 200 * 1.2
        and inked_mm2 > 1.8 * ink(plots["thin"]).sum() / (DPI / 25.4) ** 2
    )


def test_sim_serve_on_a_pty_until_ctrl_c(tmp_path):
    out = tmp_path / "served.png"
    proc = subprocess.Popen(
        [sys.executable, "-m", "pencilbot.cli", "sim-serve", "--realtime", "0", "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        path = proc.stdout.readline().strip()
        assert path.startswith("/dev/")
        with serial.Serial(path, 115200, timeout=ANSWER_WAIT) as port:
            # Opening resets the board like an Arduino's DTR; a soft reset too: the status report
            # asked for after it ends both banners, whenever they come.
            port.write(grbl.SOFT_RESET + grbl.STATUS_QUERY)
            assert b"Grbl 1.1h ['$' for help]\r\n" in until_report(port)
            for line in SQUARE.splitlines():
                port.write(grbl.encode_line(line))
                assert port.readline() == b"ok\r\n"
    finally:
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=20)
    assert proc.returncode == 0, stderr
    assert "12 lines accepted" in stdout
    assert ink(out).max() > 0.5


def serve(tmp_path, *argv):
    """A running ``sim-serve`` and its first device path."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "pencilbot.cli", "sim-serve", "--realtime", "0", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    return proc, proc.stdout.readline().strip()


#: s to wait for an answer that is known to come (a line returns as soon as it arrives): 0.1 s
#: was too short for the server process on a loaded machine (b'' instead of ok).
ANSWER_WAIT = 10.0


def until_report(port) -> bytes:
    """What the board sends up to and with the next status report (the end of any banners)."""
    seen = b""
    while not seen.endswith(b">\r\n"):
        line = port.readline()
        assert line, f"no status report, got {seen!r}"
        seen += line
    return seen


def stream(path, lines):
    with serial.Serial(path, 115200, timeout=ANSWER_WAIT) as port:
        port.write(grbl.STATUS_QUERY)  # the open resets the board, like an Arduino: its banner
        until_report(port)  # comes first, whenever it comes
        for line in lines:
            port.write(grbl.encode_line(line))
            assert port.readline() == b"ok\r\n"


def test_sim_serve_plays_a_real_board_unless_told_otherwise():
    from pencilbot.cli import build_parser
    from sim.gcode.plotter import REAL_BOARD

    args = build_parser().parse_args(["sim-serve"])
    assert {key: getattr(args, key) for key in REAL_BOARD} == REAL_BOARD and not args.no_reset


def test_sim_serve_saves_its_drawing_on_sigterm(tmp_path):
    out = tmp_path / "served.png"
    proc, path = serve(tmp_path, "-o", str(out))
    try:
        stream(path, SQUARE.splitlines())
    finally:
        proc.send_signal(signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=20)
    assert proc.returncode == 0, stderr
    assert "12 lines accepted" in stdout and ink(out).max() > 0.5


def test_sim_serve_stops_on_sigint_even_started_ignoring_it(tmp_path):
    # A script's background job starts with SIGINT ignored; sim-serve still ends on it, saving
    # its drawing (before, it went on serving and the test's child was left running).
    out = tmp_path / "served.png"
    proc = subprocess.Popen(
        [sys.executable, "-m", "pencilbot.cli", "sim-serve", "--realtime", "0", "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),
    )
    try:
        stream(proc.stdout.readline().strip(), SQUARE.splitlines())
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, stderr
    assert "12 lines accepted" in stdout and ink(out).max() > 0.5


def test_sim_serve_keeps_serving_after_a_dropped_link(tmp_path):
    out = tmp_path / "served.png"
    proc, path = serve(tmp_path, "--faults", "drop@3", "-o", str(out))
    try:
        with serial.Serial(
            path, 115200, timeout=0.1
        ) as port:  # (its bytes reach the board after the open's reset)
            for line in SQUARE.splitlines()[:3]:
                port.write(grbl.encode_line(line))
            with pytest.raises(serial.SerialException):  # line 3 pulls the cable
                end = time.monotonic() + ANSWER_WAIT  # a bound for a broken run only
                while time.monotonic() < end:
                    port.read(100)
        again = proc.stdout.readline().strip()  # the board is plugged back in elsewhere
        assert again.startswith("/dev/")
        stream(again, SQUARE.splitlines()[2:])
    finally:
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=20)
    assert proc.returncode == 0, stderr
    assert "12 lines accepted" in stdout and ink(out).max() > 0.5


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--dpi", "0", "-o", "x.png"], "--dpi must be at least 1"),
        (["--dpi", "9000", "-o", "x.png"], "use --dpi"),
        (["--realtime", "nan"], "--realtime must be at least 0"),
        (["-o", "no/such/folder/x.png"], "folder does not exist"),
        (["--realtime", "-1"], "--realtime must be at least 0"),
        (["--emulate-baud", "-9600"], "--emulate-baud must be at least 0"),
        (["--baud", "-9600"], "--baud must be at least 0"),  # the old spelling, read the same way
    ],
)
def test_sim_serve_refuses_bad_options_before_serving(tmp_path, argv, message):
    # Without the check these would serve until Ctrl-C and only then fail to save.
    proc = subprocess.run(
        [sys.executable, "-m", "pencilbot.cli", "sim-serve", *argv],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode != 0 and proc.stdout == ""
    assert proc.stderr.startswith("pencilbot: error:") and message in proc.stderr


def test_simulate_on_a_machine_short_of_memory_for_one_band_says_so(tmp_path, capsys, monkeypatch):
    # The render's memory is one band's (~4 M pixels), whatever the bed: with 50 MB free even
    # that does not fit, and the command says so before streaming anything.
    from pencilbot.app import photo as app_photo

    monkeypatch.setattr(app_photo, "available_memory", lambda: 50_000_000)
    src, out = tmp_path / "square.gcode", tmp_path / "plot.png"
    src.write_text(SQUARE)
    assert main(["simulate", str(src), "-o", str(out), "--dpi", "600"]) == 2
    err = capsys.readouterr().err
    assert (
        "a band of rows at a time needs about 160 MB, more than the 38 MB pencilbot may use (75% of the 50 MB "
        in err
    )
    assert not out.exists()
    monkeypatch.setattr(app_photo, "available_memory", lambda: 400_000_000)  # a band fits: it runs
    assert main(["simulate", str(src), "-o", str(out), "--dpi", "600", "-q"]) == 0 and out.exists()


def test_sim_serve_outlives_its_senders_and_saves_what_they_drew_on_sigterm(tmp_path):
    # Two `pencilbot draw` processes one after the other, each opening, streaming and closing the
    # pty (the board resets on each first open, as an Arduino does): the server serves both.
    first, second = tmp_path / "first.gcode", tmp_path / "second.gcode"
    first.write_text(SQUARE)
    second.write_text(
        SQUARE.replace("X20 Y20", "X120 Y120")
        .replace("X60", "X160")
        .replace("Y60", "Y160")
        .replace("X20\n", "X120\n")
        .replace("Y20\n", "Y120\n")
    )
    out = tmp_path / "served.png"
    proc, path = serve(tmp_path, "-o", str(out), "--dpi", str(DPI))  # a real board: zeroed on each open
    try:
        for job in (first, second):
            drawn = subprocess.run(
                [sys.executable, "-m", "pencilbot.cli", "draw", str(job), "--port", path, "-q"],
                capture_output=True,
                text=True,
                timeout=60,
            )
            assert drawn.returncode == 0, drawn.stderr
    finally:
        proc.send_signal(signal.SIGTERM)
        _stdout, stderr = proc.communicate(timeout=20)
    assert proc.returncode == 0, stderr
    dark = ink(out)
    rows = dark.shape[0]
    for x, y in ((40, 20), (60, 40), (140, 120), (160, 140)):  # an edge of each square
        r, c = px(rows, x, y)
        assert dark[r - 1 : r + 2, c - 1 : c + 2].max() > 0.5, (x, y)
