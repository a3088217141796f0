"""The end of a GRBL job: the driver returns only once the board has run every move.

GRBL prints a status report the moment its protocol loop next checks for realtime commands. A
``?`` that reaches the board while it parses the last line is answered right after that line's
``ok`` but before GRBL starts the cycle, so that report says ``Idle`` with the move still queued.
The virtual plotter runs its lines atomically and cannot show this window, so the board here is a
small scripted GRBL on a real pty that always answers the last line that way.
"""

from pty_board import PtyBoard

from pencilbot.driver import draw

JOB = ["G21", "G90", "G0X10Y10", "G1X30Y30F1000"]
IDLE = "<Idle|MPos:{0},{0},0.000|FS:0,0>"
RUN = "<Run|MPos:20.000,20.000,0.000|FS:1000,0>"


class LateCycleStartBoard(PtyBoard):
    """Answers ``ok`` per line; holds the last line's ``ok`` until a ``?`` comes, then sends the
    ``ok`` and a stale Idle report together, then reports Run twice, then Idle (drawn)."""

    newline = "\r\n"

    def __init__(self):
        super().__init__()
        self.holding_last = False
        self.runs_left = 0
        self.started = False  # the last line has arrived
        self.drawn_reported = False  # the board said Idle after running the last move

    def _status(self):
        if self.holding_last:  # the "?" arrived while the last line was being parsed
            self.holding_last, self.runs_left = False, 2
            self._say("ok", IDLE.format("0.000"))
        elif self.runs_left:
            self.runs_left -= 1
            self._say(RUN)
        else:
            self.drawn_reported = self.started  # after the last line, Idle comes only once drawn
            self._say(IDLE.format("30.000" if self.started else "0.000"))

    def _serve(self):
        self._serve_lines()

    def _realtime(self, byte) -> bool:
        if byte == ord("?"):
            self._status()
            return True
        return False

    def _line(self, text):
        if text == JOB[-1]:
            self.holding_last, self.started = True, True
        else:
            self._say("ok")


def test_a_stale_idle_report_after_the_last_ok_does_not_end_the_job():
    with LateCycleStartBoard() as board:
        draw(JOB, board.path, profile="grbl-servo-a4", wake_wait=0.2, timeout=5)
        assert board.drawn_reported
