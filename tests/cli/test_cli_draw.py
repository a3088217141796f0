"""`pencilbot draw` argument handling: every user mistake is one plain message, never a traceback."""

from pencilbot.cli import main


def run(capsys, *argv):
    code = main(["draw", *argv])
    return code, capsys.readouterr().err


def test_missing_file_says_which_and_what_to_do(capsys, tmp_path):
    code, err = run(capsys, str(tmp_path / "nope.gcode"), "--port", "sim://")
    assert code == 2 and "no such file" in err and "Traceback" not in err


def test_missing_port_is_asked_for(capsys, tmp_path):
    (tmp_path / "a.gcode").write_text("G21\n")
    code, err = run(capsys, str(tmp_path / "a.gcode"))
    assert code == 2 and "--port" in err


def test_unopenable_port_names_the_port(capsys, tmp_path):
    (tmp_path / "a.gcode").write_text("G21\n")
    code, err = run(capsys, str(tmp_path / "a.gcode"), "--port", str(tmp_path / "ttyNOPE"))
    assert code == 3 and "could not open port" in err and "ttyNOPE" in err


def test_resume_without_journal_explains(capsys, tmp_path):
    code, err = run(capsys, "--resume", str(tmp_path / "job.gcode"), "--port", "sim://")
    assert code == 2 and "no job journal" in err


def test_empty_gcode_is_refused_before_opening_the_port(capsys, tmp_path):
    (tmp_path / "e.gcode").write_text("; only a comment\n\n")
    code, err = run(capsys, str(tmp_path / "e.gcode"), "--port", str(tmp_path / "ttyNOPE"))
    assert code == 2 and "no G-code commands" in err


def test_start_line_outside_the_file(capsys, tmp_path):
    (tmp_path / "a.gcode").write_text("G21\nG90\n")
    code, err = run(capsys, str(tmp_path / "a.gcode"), "--port", "sim://", "--start-line", "9")
    assert code == 2 and "outside" in err


def test_resume_and_start_line_exclude_each_other(capsys):
    assert main(["draw", "x.gcode", "--resume", "j", "--start-line", "3"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pencilbot: error: argument --start-line") and err.count("\n") == 1, err


#: A line of ordinary numbers (none over 24 characters) too long for GRBL's 80-byte line buffer.
LONG_LINE = "G1 X1." + "0" * 20 + " Y1." + "0" * 20 + " Z0." + "0" * 20 + " F1000." + "0" * 17


def test_a_line_grbl_cannot_take_is_named_before_anything_is_sent(capsys, tmp_path):
    (tmp_path / "long.gcode").write_text("G21 ; ünïcode comments are fine\n" + LONG_LINE + "\n")
    code, err = run(capsys, str(tmp_path / "long.gcode"), "--port", str(tmp_path / "ttyNOPE"))
    assert code == 2 and "line 2 of" in err and "at most 79" in err


def test_a_photo_input_gets_the_export_command_to_run_first(capsys, tmp_path):
    code, err = run(capsys, str(tmp_path / "cat.jpg"), "--port", "/dev/ttyUSB0", "--profile", "grbl-z-a3")
    assert code == 2 and "is a picture, not G-code" in err
    assert f"pencilbot export {tmp_path / 'cat.jpg'} -o {tmp_path / 'cat.gcode'} --profile grbl-z-a3" in err


def test_a_binary_file_is_named_as_not_gcode_before_the_port_is_opened(capsys, tmp_path):
    path = tmp_path / "photo.gcode"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)))
    code, err = run(capsys, str(path), "--port", "/dev/no-such-port")
    assert code == 2 and "is not G-code text" in err and "Traceback" not in err


def test_verbose_draw_says_where_what_and_how_long_before_streaming(capsys, tmp_path):
    import numpy as np

    import sim
    from pencilbot.export.gcode import write_gcode
    from pencilbot.machine.profile import load_profile
    from pencilbot.planning.plan import Layer, Page, Plan
    from pencilbot.planning.stats import duration_text

    sim.register()
    plan = Plan(
        Page(210.0, 297.0, name="A4"),
        [Layer("edges", [np.array([[30.0, 30.0], [90.0, 60.0], [90.0, 90.0]])])],
    )
    path = tmp_path / "v.gcode"
    summary = write_gcode(plan, load_profile("grbl-servo-a4"), path)
    code = main(["draw", str(path), "--port", "sim://verbose", "--baud", "57600", "-v", "--json-lines"])
    err = capsys.readouterr().err
    lines = sum(1 for line in path.read_text().splitlines() if line.split(";")[0].strip())
    assert code == 0
    assert err.splitlines()[:5] == [
        "port sim://verbose at 57600 bit/s",
        "profile grbl-servo-a4 (plotters/grbl-servo-a4.toml): GRBL 1.1, servo pen on spindle PWM (M3 S30 up / "
        "M3 S90 down), A4 portrait bed",
        "board: Grbl 1.1h",
        f"job: {path}, {lines} command lines of {len(path.read_text().splitlines())}",
        f"estimated plot time {duration_text(summary.stats.total.seconds)} (the file's estimate)",
    ]


def _plot(tmp_path):
    import sys

    sys.path.insert(0, str(__import__("pathlib").Path(__file__).parents[1] / "driver"))
    from test_stream_sim import drawing

    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(drawing()) + "\n")
    return path


def test_a_stopped_job_is_not_drawn_again_from_line_1_without_restart(capsys, tmp_path):
    import json

    from sim import protocol_sim

    path = _plot(tmp_path)
    profile = tmp_path / "mine.toml"
    profile.write_text(
        (__import__("pathlib").Path(__file__).parents[2] / "configs/plotters/grbl-servo-a4.toml").read_text()
    )
    code, err = run(
        capsys,
        str(path),
        "--port",
        "sim://jobs1?faults=error@30",
        "--profile",
        str(profile),
        "--send-and-wait",
        "--baud",
        "57600",
        "--timeout",
        "3",
        "-q",
    )
    assert code != 0 and "Resume with: pencilbot draw --resume" in err
    journal = json.loads((tmp_path / "plot.gcode.job.json").read_text())
    # Every connection option, and a profile path that works from any folder.
    assert journal["options"] == {"baud": 57600, "timeout": 3.0, "send_and_wait": True, "on_error": "stop"}
    assert journal["profile"] == str(profile.resolve()) and journal["resume"] in err
    sent = len(protocol_sim.plotter("jobs1").firmware.log)
    code, err = run(capsys, str(path), "--port", "sim://jobs1")
    assert code == 2 and "stopped at line" in err and journal["resume"] in err and "--restart" in err
    record = path.with_name(path.name + ".job.json")
    record.write_text(
        json.dumps({**json.loads(record.read_text()), "status": "running"})
    )  # a killed sender's
    code, err = run(capsys, str(path), "--port", "sim://jobs1")
    assert (
        code == 2
        and "is being drawn now (on sim://jobs1" in err
        and "or its sender was killed at line" in err
    )
    assert journal["resume"] in err
    record.write_text(json.dumps({**json.loads(record.read_text()), "status": "stopped"}))
    assert len(protocol_sim.plotter("jobs1").firmware.log) == sent  # nothing was sent
    code, err = run(capsys, str(path), "--port", "sim://jobs1", "--profile", str(profile), "--restart", "-q")
    assert code == 0, err
    assert not (tmp_path / "plot.gcode.job.json").exists()  # finished: nothing to resume


def test_sigterm_stops_safely_and_prints_the_resume_command(tmp_path):
    import json
    import signal
    import subprocess
    import sys
    import time

    path = _plot(tmp_path)
    command = [
        sys.executable,
        "-c",
        "from pencilbot.cli import main; raise SystemExit(main())",
        "draw",
        str(path),
        "--port",
        "sim://term?realtime=2",
        "--profile",
        "grbl-servo-a4",
        "--json-lines",
    ]
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    journal = tmp_path / "plot.gcode.job.json"
    deadline = time.monotonic() + 600  # a bound for a broken run only: a loaded machine starts slowly
    while (
        proc.poll() is None
        and time.monotonic() < deadline
        and not (journal.exists() and json.loads(journal.read_text())["acked_line"] > 10)
    ):
        time.sleep(0.05)
    assert proc.poll() is None, "the plot ended before the signal"
    proc.send_signal(signal.SIGTERM)
    _out, err = proc.communicate(timeout=30)
    assert proc.returncode != 0
    assert (
        "stopped by SIGTERM" in err and "pen raised" in err and "Resume with: pencilbot draw --resume" in err
    )
    record = json.loads(journal.read_text())
    assert record["status"] == "stopped" and record["resume"] in err and record["stop_work"] is not None


def test_simulate_of_a_file_with_a_pen_change_prints_the_prompt_and_finishes(capsys, tmp_path):
    src = tmp_path / "two-pens.gcode"
    src.write_text(
        "G21\nG90\nM3 S30\nG0 X10 Y10\nM3 S90\nG1 X40 Y10 F3000\nM3 S30\n"
        "M0 (pen change: insert red)\nM3 S90\nG1 X40 Y40\nM3 S30\n"
    )
    code = main(["simulate", str(src), "-o", str(tmp_path / "p.png"), "--profile", "grbl-servo-a4"])
    captured = capsys.readouterr()
    assert code == 0 and "paused: pen change: insert red (simulate presses cycle start)" in captured.err
    assert "2 pen-down strokes" in captured.out
