"""A reply the driver did not ask for is a stop with a message, never success: another program
writing to the port mid-job (its line runs on the plotter and is answered with an ok too many),
or a board that sends back the lines it gets."""

import errno
import os
import threading

from pty_board import PtyBoard
from test_port_exclusive import other_program_opens
from test_port_in_use import _catch
from test_stream_sim import PROFILE, drawing

from pencilbot.cli import main
from pencilbot.machine.profile import load_profile
from sim.gcode.plotter import VirtualPlotter
from sim.pty_server import PtyServer

FOREIGN = b"G0X200Y300\n"


def test_another_program_writing_to_the_port_mid_job_stops_the_job_with_a_message(tmp_path, capsys):
    lines = drawing()
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(lines) + "\n")
    plotter = VirtualPlotter(load_profile(PROFILE), baud=115200, realtime=4)
    results = []
    with PtyServer(plotter) as server:
        os.chmod(server.path, 0o666)  # as a USB adapter in the dialout group: others may open it
        sender = threading.Thread(
            target=lambda: _catch(
                results, main, ["draw", str(path), "--port", server.path, "--profile", PROFILE, "-q"]
            )
        )
        sender.start()
        try:
            while sender.is_alive() and len(plotter.firmware.accepted_lines()) < 25:
                sender.join(0.01)
            assert sender.is_alive(), "the job ended before the other program wrote"
            # Root can open the port the job holds (TIOCEXCL does not stop root): it writes one line.
            other = os.open(server.path, os.O_WRONLY | os.O_NOCTTY)
            try:
                os.write(other, FOREIGN)
            finally:
                os.close(other)
            # Another program that is not root cannot even open it.
            code, said = other_program_opens(server.path)
            assert code != 0 and os.strerror(errno.EBUSY) in said, said
        finally:
            sender.join(60)
    err = capsys.readouterr().err
    assert results == [3], (results, err)
    assert "the plotter answered a line pencilbot did not send: another program is writing to the port" in err
    assert "(an ok too many)" in err and "Stopped; pen raised" in err and "Traceback" not in err
    assert err.count("\n") == 1, err
    ran = [line for line in plotter.firmware.accepted_lines() if line]
    assert "G0X200Y300" in ran  # the plotter did run it: why the job cannot end as a success
    plotter.firmware.finish()
    assert not plotter.machine.pen_down
    journal = path.with_name(path.name + ".job.json")
    assert journal.exists() and '"status": "stopped"' in journal.read_text()


class EchoBoard(PtyBoard):
    """A GRBL board behind a port that sends every line back before answering it."""

    newline = "\r\n"
    woken = False

    def _serve(self):
        self._serve_lines()

    def _realtime(self, byte) -> bool:
        if byte == 0x18 or not self.woken:  # a reset, or the sender's first bytes: the banner
            self.woken = True
            self._say("Grbl 1.1h ['$' for help]")
            return True
        if byte == ord("?"):
            self._say("<Idle|MPos:0.000,0.000,0.000|FS:0,0>")
            return True
        return False

    def _line(self, text):
        self._say(*([text] if text else []), "ok")


def test_a_board_that_sends_back_the_lines_it_gets_stops_the_job(tmp_path, capsys):
    path = tmp_path / "echo.gcode"
    path.write_text("G21\nG90\nG0 X10 Y10\nG1 X30 Y30 F1000\n")
    with EchoBoard() as board:
        code = main(["draw", str(path), "--port", board.path, "--profile", PROFILE, "-q", "--timeout", "3"])
    err = capsys.readouterr().err
    assert code == 3, err
    assert "the plotter answered a line pencilbot did not send" in err
    assert "(it sent back 'G21', a command line)" in err and "Traceback" not in err, err
