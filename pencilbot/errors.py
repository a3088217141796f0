"""The one error type users see.

Anything the user can cause (a bad image, a wrong profile key, a drawing that does not fit the
bed, a firmware error, a vanished port) raises :class:`PencilbotError` with a plain message that
says what happened and what to do. The CLI prints the message without a traceback and exits with
``exit_code``.
"""


class PencilbotError(Exception):
    """A user-facing error: ``str(err)`` is the whole message."""

    exit_code = 2


class ImageLoadError(PencilbotError):
    """An input image could not be read."""


class ProfileError(PencilbotError):
    """A plotter profile or style file is invalid."""


class OutOfBedError(PencilbotError):
    """A drawing does not fit the plotter's bed."""


class PlotError(PencilbotError):
    """Streaming to a plotter stopped (firmware error, alarm, lost port, timeout)."""

    exit_code = 3
