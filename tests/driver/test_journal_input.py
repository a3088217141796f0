"""A job journal is read like user input: a tampered or damaged one (a stop point off the bed or
not a number, a line that is not one of the file's, wrong types) is one message saying what is
wrong and how to go on, before the port is opened: never a move, never success with nothing drawn."""

import json

import pytest
from test_stream_sim import PROFILE, drawing, fresh

from pencilbot.cli import main
from sim import protocol_sim


@pytest.fixture
def stopped(tmp_path, capsys):
    """A job stopped by a refused line: its G-code, journal path, port URL and plotter name."""
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(drawing()) + "\n")
    url, name = fresh("faults=error@30")
    code = main(["draw", str(path), "--port", url, "--profile", PROFILE, "-q"])
    err = capsys.readouterr().err
    assert code == 3 and "Resume with: pencilbot draw --resume" in err, err
    journal = path.with_name(path.name + ".job.json")
    assert json.loads(journal.read_text())["status"] == "stopped"
    return path, journal, f"sim://{name}", name


TAMPERED = {
    "stop_xy off the bed": (
        {"stop_xy": [5000, 5000]},
        "stop_xy [5000, 5000] is off the bed of plotter profile grbl-servo-a4 (X 0 .. 220, Y 0 .. 310 mm)",
    ),
    "stop_xy NaN": ('"stop_xy": [NaN, 1.0]', "stop_xy is [nan, 1.0], not two finite numbers (X, Y)"),
    "stop_xy infinite": (
        '"stop_xy": [Infinity, 1.0]',
        "stop_xy is [inf, 1.0], not two finite numbers (X, Y)",
    ),
    "stop_xy text": ({"stop_xy": "here"}, "stop_xy is 'here', not two finite numbers (X, Y)"),
    "stop_xy off the bed in X": ({"stop_xy": [500, 10]}, "stop_xy [500, 10] is off the bed"),
    "stop_work off the bed": (
        {"stop_work": [-50, 10], "stop_mpos": [-50, 10]},
        "stop_work [-50, 10] is off the bed",
    ),
    "stop_mpos NaN": ('"stop_mpos": [1.0, NaN]', "stop_mpos is [1.0, nan], not two finite numbers (X, Y)"),
    "stop_work alone": ({"stop_work": [10, 10], "stop_mpos": None}, "stop_work and stop_mpos go together"),
    "next_line huge": ({"next_line": 1e9}, "next_line is 1000000000.0, not a whole number of at least 1"),
    "next_line past the end": ({"next_line": 10**9}, "next_line 1000000000 is past the file's"),
    "next_line text": ({"next_line": "abc"}, "next_line is 'abc', not a whole number of at least 1"),
    "next_line zero": ({"next_line": 0}, "next_line is 0, not a whole number of at least 1"),
    "next_line true": ({"next_line": True}, "next_line is True, not a whole number of at least 1"),
    "sent_line negative": ({"sent_line": -4}, "sent_line is -4, not a whole number of at least 0"),
    "total_lines other": ({"total_lines": 500}, "total_lines is 500, and"),
    "status odd": ({"status": "finished"}, "status is 'finished', not 'running' or 'stopped'"),
    "baud text": ({"options": {"baud": "fast"}}, "options.baud is 'fast'"),
    "timeout zero": ({"options": {"timeout": 0}}, "options.timeout is 0"),
    "port number": ({"port": 5}, "port is 5, not text"),
    # An EBB stop's step positions: where a resume or a re-zero looks for the pen.
    "ebb_moves short": ({"options": {"ebb_moves": [[0, 0, 10]]}}, "options.ebb_moves is [[0, 0, 10]]"),
    "ebb_origin text": ({"options": {"ebb_origin": ["a", 1]}}, "options.ebb_origin is ['a', 1]"),
    "ebb_resume floats": ({"options": {"ebb_resume": [[1.5, 2, 3]]}}, "options.ebb_resume is [[1.5, 2, 3]]"),
}


@pytest.mark.parametrize("case", sorted(TAMPERED))
def test_a_tampered_journal_is_one_message_and_nothing_is_sent(stopped, capsys, case):
    path, journal, port, name = stopped
    change, wrong = TAMPERED[case]
    text = journal.read_text()
    if isinstance(change, str):  # JSON's non-standard literals, as Python's json reads them
        key = change.split(":")[0]
        record = json.loads(text)
        record.pop(key.strip('"'))
        text = json.dumps(record)[:-1] + f", {change}}}"
    else:
        text = json.dumps({**json.loads(text), **change})
    journal.write_text(text)
    sent = len(protocol_sim.plotter(name).firmware.log)
    code = main(["draw", "--resume", str(journal), "--port", port, "-q"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith(f"pencilbot: error: job journal {journal} is unreadable or was edited: {wrong}"), (
        err
    )
    assert "nothing was sent" in err and "--start-line N" in err and "--restart" in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert len(protocol_sim.plotter(name).firmware.log) == sent  # not a byte more reached the board
    # Drawing the file without --resume does not quietly replace that journal either.
    code = main(["draw", str(path), "--port", port, "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "--restart" in err and "Traceback" not in err, err
    assert len(protocol_sim.plotter(name).firmware.log) == sent


def test_the_untampered_journal_resumes_and_finishes(stopped, capsys):
    _path, journal, port, _name = stopped
    code = main(["draw", "--resume", str(journal), "--port", port, "-q"])
    assert code == 0, capsys.readouterr().err
    assert not journal.exists()


def test_a_stop_point_is_checked_on_the_bed_through_the_file_s_work_offset_in_x_and_y(tmp_path, capsys):
    # G92 makes work X 0 machine X 100 (Y unchanged): a stop point at work X 150 is machine
    # X 250, off the 220 mm bed, though 150 itself would be on it.
    lines = [
        "G21",
        "G90",
        "M3 S30",
        "G4 P0.15",
        "G0 X100 Y20",
        "G92 X0 Y20",
        "M3 S90",
        "G4 P0.2",
        *[f"G1 X{10 * i} Y{20 + (i % 2)} F3000" for i in range(1, 10)],
        "M3 S30",
        "G4 P0.15",
    ]
    path = tmp_path / "offset.gcode"
    path.write_text("\n".join(lines) + "\n")
    url, name = fresh("faults=error@16")
    assert main(["draw", str(path), "--port", url, "--profile", PROFILE, "-q"]) == 3
    capsys.readouterr()
    journal = path.with_name(path.name + ".job.json")
    record = json.loads(journal.read_text())
    assert record["next_line"] > 6  # after the G92
    for stop_xy, refused in (([150.0, 20.0], True), ([60.0, 20.0], False)):
        journal.write_text(json.dumps({**record, "stop_xy": stop_xy}))
        code = main(["draw", "--resume", str(journal), "--port", f"sim://{name}", "-q"])
        err = capsys.readouterr().err
        assert code == 2 and (f"stop_xy {stop_xy} is off the bed" in err) == refused, err
        # (On the bed, the resume is refused for what it cannot restore: the G92.)
        assert refused or "change the work coordinates (G92, G10, G54-G59)" in err, err
