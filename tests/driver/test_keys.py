"""The terminal's keys during draw, on a real pseudo-terminal (cbreak mode, restored after)."""

import os
import termios
import threading
import time

from pencilbot.driver.keys import KeyReader, TerminalOperator


def _wait_for(predicate, seconds=2.0):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.01)
    return predicate()


def test_keys_pause_and_stop_and_the_terminal_mode_comes_back():
    master, slave = os.openpty()
    with os.fdopen(slave, "rb", buffering=0) as terminal:
        before = termios.tcgetattr(slave)
        keys = KeyReader(terminal)
        assert not termios.tcgetattr(slave)[3] & termios.ICANON  # no Enter needed
        os.write(master, b"px s")
        got = []
        assert _wait_for(lambda: got.extend(keys.poll()) or len(got) >= 3)
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
        done = threading.Event()
        waiter = threading.Thread(
            target=lambda: (operator.pause("paused: pen change: insert red"), done.set()), daemon=True
        )
        waiter.start()
        os.write(master, b"p")
        assert not done.wait(0.2)  # only Enter goes on
        os.write(master, b"\n")
        assert done.wait(2)
        waiter.join(timeout=2)
        moves = []
        os.write(master, b"3l2jk\n")
        operator.jog_to_mark("jog to the origin", None, lambda dx, dy: moves.append((dx, dy)))
        assert moves == [(10.0, 0.0), (0.0, -1.0), (0.0, 1.0)]
        keys.close()
    os.close(master)
    assert "insert red" in (tmp_path / "err.txt").read_text()


def test_the_pause_key_holds_a_running_plot_without_timing_out_and_the_stop_key_stops_it(tmp_path):
    import pytest
    from segments import assert_same_drawing
    from test_fault_matrix import LINES, MOVING, PROFILE, WAKE_LINES, drawn
    from test_stream_sim import HandOnTheMachine

    from pencilbot.driver import draw
    from pencilbot.errors import PlotError
    from sim import protocol_sim

    reference_name = "keys-ref"
    draw(LINES, f"sim://{reference_name}", profile=PROFILE, wake_wait=0.2)
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(LINES) + "\n")
    master, slave = os.openpty()
    with os.fdopen(slave, "rb", buffering=0) as terminal:
        keys = KeyReader(terminal)
        held = []

        def press():
            firmware = lambda: protocol_sim.plotter("keys1").firmware  # noqa: E731
            _wait_for(lambda: "keys1" in protocol_sim._PLOTTERS and len(firmware().log) > WAKE_LINES + 10)
            os.write(master, b"p")
            held.append(_wait_for(lambda: firmware().state() == "Hold:0"))
            time.sleep(0.6)  # longer than the timeout: a held board still answers
            os.write(master, b"p")
            _wait_for(lambda: len(firmware().log) > WAKE_LINES + MOVING + 1)
            os.write(master, b"s")

        presser = threading.Thread(target=press, daemon=True)
        presser.start()
        try:
            with pytest.raises(PlotError, match="stopped by the stop key .*pen raised"):
                draw(path, "sim://keys1?realtime=100", profile=PROFILE, wake_wait=0.2, timeout=0.3, keys=keys)
        finally:
            presser.join(timeout=10)
            keys.close()
    os.close(master)
    assert held == [True]
    draw(
        path,
        "sim://keys1",
        resume=f"{path}.job.json",
        wake_wait=0.2,
        operator=HandOnTheMachine(protocol_sim.plotter("keys1")),
    )
    assert_same_drawing(drawn("keys1"), drawn(reference_name))
