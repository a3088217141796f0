"""The terminal's keys during draw, on a real pseudo-terminal (cbreak mode, restored after).

No test waits on the wall clock for a result: keys are typed and then read back through the
reader, and during a plot the virtual board itself types them at the moments it reaches (a
line, its hold, the status queries it answered while held), waiting until the reader has the key
before it goes on.
"""

import os
import termios

from waiting import until

from pencilbot.driver.keys import KeyReader, TerminalOperator


def test_keys_pause_and_stop_and_the_terminal_mode_comes_back():
    master, slave = os.openpty()
    with os.fdopen(slave, "rb", buffering=0) as terminal:
        before = termios.tcgetattr(slave)
        keys = KeyReader(terminal)
        assert not termios.tcgetattr(slave)[3] & termios.ICANON  # no Enter needed
        os.write(master, b"px s")
        got = []
        until(lambda: got.extend(keys.poll()) or len(got) >= 3, "three requests")
        assert got == ["pause", "pause", "stop"]  # x is no key of ours
        keys.close()
        assert termios.tcgetattr(slave) == before
        assert not keys._thread.is_alive()  # noqa: SLF001 - nothing reads the terminal after the plot
    os.close(master)


def test_a_pen_change_prompt_waits_for_enter_and_a_jog_follows_the_keys(tmp_path):
    master, slave = os.openpty()
    with os.fdopen(slave, "rb", buffering=0) as terminal, open(tmp_path / "err.txt", "w") as out:
        keys = KeyReader(terminal)
        operator = TerminalOperator(keys, out=out)
        # Only Enter goes on: a prompt that took the p would leave the Enter to the jog below,
        # which would then end before its first key.
        os.write(master, b"p\n")
        operator.pause("paused: pen change: insert red")
        moves = []
        os.write(master, b"3l2jk\n")
        operator.jog_to_mark("jog to the origin", None, lambda dx, dy: moves.append((dx, dy)))
        assert moves == [(10.0, 0.0), (0.0, -1.0), (0.0, 1.0)]
        keys.close()
    os.close(master)
    assert "insert red" in (tmp_path / "err.txt").read_text()


class BoardThatTypes:
    """The virtual board ``name``, typing keys on the terminal at moments of its own: ``p``
    once ``WAKE_LINES + 10`` job lines came, ``p`` again after it answered ``queries`` status
    queries in its hold (the sender's poll: longer than its timeout), ``s`` once the line it
    was drawing when the fault matrix stops came. Each key is in the reader before the board
    goes on, so the sender's next look at the keys finds it."""

    def __init__(self, name, master, keys, queries):
        import serial

        from sim import protocol_sim

        protocol_sim.forget(name)
        serial.serial_for_url(f"sim://{name}?realtime=100").close()
        self.plotter = protocol_sim.plotter(name)
        self.master, self.keys, self.queries = master, keys, queries
        self.step, self.held, self.queries_at_hold = 0, [], 0
        self._pump = self.plotter.pump
        self.plotter.pump = self.pump

    def _type(self, key: bytes) -> None:
        os.write(self.master, key)
        until(lambda: self.keys._keys.qsize(), f"the reader has {key!r}")  # noqa: SLF001
        self.step += 1

    def pump(self) -> None:
        from test_fault_matrix import MOVING, WAKE_LINES

        self._pump()
        firmware = self.plotter.firmware
        lines = len(firmware.log)
        if self.step == 0 and lines > WAKE_LINES + 10:
            self._type(b"p")
        elif self.step == 1 and firmware.state() == "Hold:0":
            self.held.append(True)
            self.queries_at_hold, self.step = firmware.queries, 2
        elif self.step == 2 and firmware.queries >= self.queries_at_hold + self.queries:
            self._type(b"p")
        elif self.step == 3 and lines > WAKE_LINES + MOVING + 1:
            self._type(b"s")


def test_the_pause_key_holds_a_running_plot_without_timing_out_and_the_stop_key_stops_it(tmp_path):
    import pytest
    from segments import assert_same_drawing
    from test_fault_matrix import LINES, PROFILE, drawn
    from test_stream_sim import HandOnTheMachine

    from pencilbot.driver import draw
    from pencilbot.driver.gcode.session import POLL_INTERVAL
    from pencilbot.errors import PlotError

    reference_name = "keys-ref"
    draw(LINES, f"sim://{reference_name}", profile=PROFILE, wake_wait=0.2)
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(LINES) + "\n")
    timeout = 0.5  # the sender's: shorter than the hold, longer than its status poll
    queries = int(2 * timeout / POLL_INTERVAL) + 1  # held for at least twice the timeout
    master, slave = os.openpty()
    with os.fdopen(slave, "rb", buffering=0) as terminal:
        keys = KeyReader(terminal)
        board = BoardThatTypes("keys1", master, keys, queries)
        try:
            with pytest.raises(PlotError, match="stopped by the stop key .*pen raised"):
                draw(path, "sim://keys1", profile=PROFILE, wake_wait=0.2, timeout=timeout, keys=keys)
        finally:
            keys.close()
    os.close(master)
    assert board.held == [True] and board.step == 4
    draw(
        path,
        "sim://keys1",
        resume=f"{path}.job.json",
        wake_wait=0.2,
        operator=HandOnTheMachine(board.plotter),
    )
    assert_same_drawing(drawn("keys1"), drawn(reference_name))
