"""A job whose journal cannot be written mid-job (a full disk, its folder gone) stops as any
fault does: feed hold, pen raised, and a message that says where the resume information is,
or, written nowhere, prints it in full (the command with its line and stop point).

The failure is a real one of the file system, not a mock: the tests run as root, whom a
read-only folder does not stop, so the journal's own path is made a folder mid-job (renaming the
new journal over it fails with EISDIR / ENOTEMPTY); the user's state folder is a file when the
fallback must fail too."""

import json
import threading

import pytest
from test_port_in_use import _catch
from test_stream_sim import PROFILE, drawing, fresh

from pencilbot.cli import main
from pencilbot.driver.journal import Journal, save_stopped
from sim import protocol_sim


def run_until_the_journal_breaks(path, url):
    """Draw ``path`` in a thread; once it has acknowledged 10 lines, turn its journal into a folder."""
    journal = path.with_name(path.name + ".job.json")
    results = []
    sender = threading.Thread(
        target=lambda: _catch(results, main, ["draw", str(path), "--port", url, "--profile", PROFILE, "-q"])
    )
    sender.start()
    try:
        broken = False
        while sender.is_alive() and not broken:
            try:
                if json.loads(journal.read_text())["acked_line"] > 10:
                    journal.unlink()
                    journal.mkdir()
                    (journal / "full").write_text("")  # a folder the new journal cannot replace
                    broken = True
            except (OSError, ValueError):
                pass  # not written yet, or written again between our two steps: try again
            sender.join(0.005)
        assert broken, "the job ended before its journal could be broken"
    finally:
        sender.join(60)
    return results


@pytest.fixture
def job(tmp_path):
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(drawing(strokes=12)) + "\n")
    return path


def test_the_stop_runs_and_the_journal_goes_to_the_state_folder(job, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    url, name = fresh("realtime=4")
    assert run_until_the_journal_breaks(job, url) == [3]
    err = capsys.readouterr().err
    assert err.startswith("pencilbot: error: the job journal could not be written (Is a directory) at line ")
    assert "Stopped; pen raised" in err and "Traceback" not in err and err.count("\n") == 1, err
    moved = list((tmp_path / "state" / "pencilbot" / "jobs").iterdir())
    assert len(moved) == 1
    assert (
        f"The job journal could not be written at {job}.job.json (Is a directory), so it is at {moved[0]}."
        in err
    )
    record = json.loads(moved[0].read_text())
    assert record["status"] == "stopped" and record["stop_work"] is not None
    assert err.rstrip().endswith(f"Resume with: {record['resume']}") and str(moved[0]) in record["resume"]
    plotter = protocol_sim.plotter(name)
    plotter.firmware.finish()
    assert not plotter.machine.pen_down
    # That journal resumes the job to its end.
    assert main(["draw", "--resume", str(moved[0]), "--port", f"sim://{name}", "-q"]) == 0, (
        capsys.readouterr().err
    )
    assert not moved[0].exists()


def test_written_nowhere_the_message_holds_the_whole_resume(job, tmp_path, monkeypatch, capsys):
    (tmp_path / "state").write_text("not a folder")
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    url, name = fresh("realtime=4")
    assert run_until_the_journal_breaks(job, url) == [3]
    err = capsys.readouterr().err
    assert "Stopped; pen raised" in err and "Traceback" not in err and err.count("\n") == 1, err
    assert (
        f"The job journal could not be written at {job}.job.json (Is a directory) or at {tmp_path}/state/"
        in err
    )
    assert "(Not a directory); what it would hold: the job goes on at line" in err
    command = err.rstrip().split("Resume with: ")[-1]
    line = int(command.split("--start-line ")[-1])
    assert command == f"pencilbot draw {job} --port '{url}' --start-line {line}"
    plotter = protocol_sim.plotter(name)
    plotter.firmware.finish()
    assert not plotter.machine.pen_down
    # The command printed finishes the job once the folder can hold a journal again.
    (job.parent / (job.name + ".job.json") / "full").unlink()
    (job.parent / (job.name + ".job.json")).rmdir()
    assert main(["draw", str(job), "--port", f"sim://{name}", "--start-line", str(line), "-q"]) == 0, (
        capsys.readouterr().err
    )


def test_a_stop_inside_a_move_written_nowhere_gives_its_point(tmp_path, monkeypatch):
    (tmp_path / "state").write_text("not a folder")
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    gcode = tmp_path / "plot.gcode"
    gcode.write_text("G21\n")
    where = tmp_path / "plot.gcode.job.json"
    where.mkdir()
    (where / "full").write_text("")
    journal = Journal(
        str(gcode),
        "0" * 64,
        "/dev/ttyUSB0",
        PROFILE,
        40,
        next_line=12,
        stop_xy=[10.25, 7.5],
        status="stopped",
        path=where,
    )
    advice = save_stopped(journal)
    assert advice.startswith(f"The job journal could not be written at {where} (")
    assert advice.endswith(
        f"what it would hold: the job goes on at line 12 of {gcode} (the pen stopped at "
        "X10.2500 Y7.5000 inside line 12's move, and --start-line draws that line whole). "
        f"Resume with: pencilbot draw {gcode} --port /dev/ttyUSB0 --start-line 12"
    )
