"""Job journal (atomic, round-trips, clear errors) and progress output modes."""

import io
import json

import pytest

from pencilbot.driver.journal import Journal, journal_path, load_journal
from pencilbot.driver.progress import Progress
from pencilbot.errors import PlotError


def make(tmp_path):
    gcode = tmp_path / "job.gcode"
    gcode.write_text("G21\nG90\n")
    journal = Journal(str(gcode), "abc", "sim://", "grbl-servo-a4", 2, path=journal_path(gcode))
    return gcode, journal


def test_journal_sits_next_to_the_gcode_and_round_trips(tmp_path):
    gcode, journal = make(tmp_path)
    journal.acked_line, journal.next_line, journal.stop_xy, journal.status = 1, 2, [1.5, 2.0], "stopped"
    journal.save()
    assert journal.path == tmp_path / "job.gcode.job.json"
    for where in (journal.path, gcode):  # by journal or by the G-code it belongs to
        assert load_journal(where) == journal
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job.gcode", "job.gcode.job.json"]


def test_journal_updates_replace_the_file_whole(tmp_path):
    _, journal = make(tmp_path)
    for n in range(1, 30):
        journal.acked_line = n
        journal.save()
        assert json.loads(journal.path.read_text())["acked_line"] == n
    assert len(list(tmp_path.iterdir())) == 2


def test_missing_or_broken_journal_is_a_plain_error(tmp_path):
    with pytest.raises(PlotError, match="no job journal"):
        load_journal(tmp_path / "nothing.gcode")
    (tmp_path / "bad.gcode.job.json").write_text("{not json")
    with pytest.raises(PlotError, match="unreadable.*--start-line"):
        load_journal(tmp_path / "bad.gcode.job.json")


@pytest.mark.parametrize("text", ['"a string"', "[1, 2]", "3", "null", '{"format": 1, "gcode": 5}'])
def test_json_that_is_not_a_journal_is_a_plain_error(tmp_path, text):
    (tmp_path / "odd.gcode.job.json").write_text(text)
    with pytest.raises(PlotError, match="unreadable.*--start-line"):
        load_journal(tmp_path / "odd.gcode.job.json")


def test_json_lines_progress_reports_lines_percent_of_plot_time_state_and_end():
    out = io.StringIO()
    progress = Progress("json", total_lines=4, total_seconds=10.0, out=out)
    progress.update(2, 2.0, "Run")  # half the lines, a fifth of the plot time
    progress.update(4, 10.0, "Idle")  # the last line is always reported
    progress.close("done")
    records = [json.loads(l) for l in out.getvalue().splitlines()]
    assert [r["event"] for r in records] == ["progress", "progress", "done"]
    assert (records[0]["line"], records[0]["percent"], records[0]["state"]) == (2, 20.0, "Run")
    assert records[1]["percent"] == 100.0 and records[1]["elapsed_s"] >= 0


def test_quiet_progress_prints_nothing():
    out = io.StringIO()
    progress = Progress("quiet", total_lines=4, total_seconds=1.0, out=out)
    progress.update(4, 1.0, "Idle")
    progress.close("done")
    assert out.getvalue() == ""


def test_unknown_progress_mode_is_refused():
    with pytest.raises(ValueError):
        Progress("loud", 1, 1.0)


def test_eta_is_the_motion_estimate_left_slowed_to_the_observed_pace():
    progress = Progress("quiet", total_lines=10, total_seconds=100.0)
    assert progress.eta(0.0) == pytest.approx(100.0, rel=0.01)  # nothing known yet: the estimate
    progress.started -= 40.0  # 40 s of wall time went by ...
    assert progress.eta(20.0) == pytest.approx(80.0 * 2.0, rel=0.01)  # ... for 20 s of motion
    assert progress.eta(60.0) == pytest.approx(40.0, rel=0.01)  # never faster than the estimate


def test_the_bar_shows_percent_of_plot_time_elapsed_time_and_where_the_job_is(capsys):
    progress = Progress("bar", total_lines=200, total_seconds=100.0)
    progress.update(50, 25.0, "Run", force=True)
    progress.close("finished")
    bar = capsys.readouterr().err.replace("\r", "\n").strip().splitlines()[-1]
    assert bar.startswith(" 25% of plot time |") and " elapsed, line 50/200, Run, ETA " in bar
    assert ", ," not in bar


@pytest.mark.parametrize("status", ["done", "stopped"])
def test_the_last_record_says_the_time_since_the_start_to_the_hundredth_and_the_listener_gets_the_same(
    status,
):
    import time

    out, heard = io.StringIO(), []
    progress = Progress("json", total_lines=4, total_seconds=10.0, out=out, listener=heard.append)
    progress.started -= 1.23456  # started that long ago (s): a time with more than two decimals
    before = time.monotonic() - progress.started
    progress.close(status, "the message")
    after = time.monotonic() - progress.started
    written = json.loads(out.getvalue().splitlines()[-1])
    assert written["event"] == heard[-1]["event"] == status
    assert written["message"] == heard[-1]["message"] == "the message"
    for elapsed in (written["elapsed_s"], heard[-1]["elapsed_s"]):
        assert round(before, 2) <= elapsed <= round(after, 2) and elapsed == round(elapsed, 2)
