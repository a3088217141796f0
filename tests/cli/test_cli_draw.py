"""`pencilbot draw` argument handling: every user mistake is one plain message, never a traceback."""

import pytest

from pencilbot.cli import main


def run(capsys, *argv):
    code = main(["draw", *argv])
    return code, capsys.readouterr().err


def test_missing_file_says_which_and_what_to_do(capsys, tmp_path):
    code, err = run(capsys, str(tmp_path / "nope.gcode"), "--port", "sim://")
    assert code == 3 and "does not exist" in err and "Traceback" not in err


def test_missing_port_is_asked_for(capsys, tmp_path):
    (tmp_path / "a.gcode").write_text("G21\n")
    code, err = run(capsys, str(tmp_path / "a.gcode"))
    assert code == 3 and "--port" in err


def test_unopenable_port_names_the_port(capsys, tmp_path):
    (tmp_path / "a.gcode").write_text("G21\n")
    code, err = run(capsys, str(tmp_path / "a.gcode"), "--port", str(tmp_path / "ttyNOPE"))
    assert code == 3 and "could not open port" in err and "ttyNOPE" in err


def test_resume_without_journal_explains(capsys, tmp_path):
    code, err = run(capsys, "--resume", str(tmp_path / "job.gcode"), "--port", "sim://")
    assert code == 3 and "no job journal" in err


def test_empty_gcode_is_refused_before_opening_the_port(capsys, tmp_path):
    (tmp_path / "e.gcode").write_text("; only a comment\n\n")
    code, err = run(capsys, str(tmp_path / "e.gcode"), "--port", str(tmp_path / "ttyNOPE"))
    assert code == 3 and "no G-code commands" in err


def test_start_line_outside_the_file(capsys, tmp_path):
    (tmp_path / "a.gcode").write_text("G21\nG90\n")
    code, err = run(capsys, str(tmp_path / "a.gcode"), "--port", "sim://", "--start-line", "9")
    assert code == 3 and "outside" in err


def test_resume_and_start_line_exclude_each_other(capsys):
    with pytest.raises(SystemExit):
        main(["draw", "x.gcode", "--resume", "j", "--start-line", "3"])


def test_a_line_grbl_cannot_take_is_named_before_anything_is_sent(capsys, tmp_path):
    (tmp_path / "long.gcode").write_text("G21 ; ünïcode comments are fine\nG1 X" + "1" * 90 + "\n")
    code, err = run(capsys, str(tmp_path / "long.gcode"), "--port", str(tmp_path / "ttyNOPE"))
    assert code == 3 and "line 2 of" in err and "at most 79" in err


def test_a_photo_input_gets_the_export_command_to_run_first(capsys, tmp_path):
    code, err = run(capsys, str(tmp_path / "cat.jpg"), "--port", "/dev/ttyUSB0", "--profile", "grbl-z-a3")
    assert code == 3 and "is a picture, not G-code" in err
    assert f"pencilbot export {tmp_path / 'cat.jpg'} -o {tmp_path / 'cat.gcode'} --profile grbl-z-a3" in err


def test_a_binary_file_is_named_as_not_gcode_before_the_port_is_opened(capsys, tmp_path):
    path = tmp_path / "photo.gcode"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)))
    code, err = run(capsys, str(path), "--port", "/dev/no-such-port")
    assert code == 3 and "is not G-code text" in err and "Traceback" not in err


def test_verbose_draw_says_where_what_and_how_long_before_streaming(capsys, tmp_path):
    from pencilbot.export.gcode import write_gcode
    from pencilbot.machine.profile import load_profile
    from pencilbot.planning.plan import Layer, Page, Plan
    from pencilbot.planning.stats import duration_text

    import numpy as np
    import sim

    sim.register()
    plan = Plan(Page(210.0, 297.0, name="A4"), [Layer("edges", [np.array([[30.0, 30.0], [90.0, 60.0], [90.0, 90.0]])])])
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
