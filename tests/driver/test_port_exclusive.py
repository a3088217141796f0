"""A tty port is exclusive at the OS level while pencilbot holds it (TIOCEXCL beside the lock),
and free again once it is closed.

The kernel lets root open an exclusive tty anyway, and the tests run as root: so the state is
read back with TIOCGEXCL, and the open that must fail is made by an unprivileged user (nobody,
through a shell, the way another program would open the port)."""

import errno
import fcntl
import os
import struct
import subprocess
import termios
import tty

import pytest

from pencilbot.driver.port import open_port
from pencilbot.errors import PlotError

TIOCGEXCL = getattr(termios, "TIOCGEXCL", 0x80045440)  # Linux: _IOR('T', 0x40, int)
NOBODY = 65534


@pytest.fixture
def pty():
    """A raw pseudo-terminal anyone may open (as a USB adapter in the dialout group is): its
    device path and our own handle on it."""
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    os.chmod(path, 0o666)
    yield path, slave
    os.close(slave)
    os.close(master)


def exclusive(fd: int) -> bool:
    return bool(struct.unpack("i", fcntl.ioctl(fd, TIOCGEXCL, b"\0" * 4))[0])


def other_program_opens(path: str) -> tuple[int, str]:
    """Another program, not root, opens the port read-write: its exit code and complaint."""
    kwargs = {"user": NOBODY} if os.geteuid() == 0 else {}
    done = subprocess.run(
        ["/bin/sh", "-c", f"exec 3<> {path} && echo opened"],
        capture_output=True,
        text=True,
        timeout=30,
        **kwargs,
    )
    return done.returncode, done.stdout + done.stderr


def test_a_tty_is_exclusive_while_open_and_free_after_close(pty):
    path, ours = pty
    assert not exclusive(ours) and other_program_opens(path) == (0, "opened\n")
    port = open_port(path)
    try:
        assert exclusive(ours)  # the device's own flag, whoever asks
        code, said = other_program_opens(path)
        assert code != 0 and os.strerror(errno.EBUSY) in said, said
        with pytest.raises(PlotError, match="is in use by another program"):
            open_port(path)  # root passes TIOCEXCL; the lock still stops a second pencilbot
    finally:
        port.close()
    assert not exclusive(ours)
    assert other_program_opens(path) == (0, "opened\n")
    open_port(path).close()  # and pencilbot can have it again


def test_closing_twice_or_after_the_device_is_gone_is_quiet(pty):
    path, ours = pty
    port = open_port(path)
    port.close()
    port.close()
    assert not exclusive(ours)
