"""The virtual plotter: GRBL's protocol in front of a G-code interpreter, a planner and a clock.

It takes a machine description (:class:`pencilbot.machine.profile.Profile`), is as unforgiving as
a real board, and is reached like one: through pyserial's ``sim://`` URLs (:func:`register`),
or on a pseudo-terminal (:mod:`sim.pty_server`).
"""


def register() -> None:
    """Make :func:`serial.serial_for_url` open ``sim://`` URLs (idempotent; nothing heavy is
    imported until a port opens)."""
    import serial

    if __name__ not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append(__name__)
