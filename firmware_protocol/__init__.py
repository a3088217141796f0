"""Firmware message grammars: pure parsing and encoding, no I/O, nothing of pencilbot.

One module per protocol (:mod:`~firmware_protocol.grbl`, :mod:`~firmware_protocol.grblhal`,
:mod:`~firmware_protocol.marlin`). A sender and the virtual plotter use the same grammar, so
neither imports the other. What cannot be encoded raises :class:`ProtocolError`.
"""


class ProtocolError(ValueError):
    """A line cannot be sent in this protocol; ``str()`` says why and what to do."""
