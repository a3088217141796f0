"""The one error type users see.

Anything the user can cause (a bad image, a wrong profile key, a drawing that does not fit the
bed, a firmware error, a vanished port) raises :class:`PencilbotError` with a plain message that
says what happened and what to do. The CLI prints the message without a traceback and exits with
``exit_code``. A message said in many places (an input that is not there) is worded here once.
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


class RefusedError(PlotError):
    """A job refused before anything was sent because its file, journal or options are wrong (a
    missing or binary file, a line the firmware cannot take, a move off the bed, a damaged
    journal, a start line past the end): the user's mistake, so the usage exit code, not the
    plotter's. A :class:`PlotError` still, for code that catches every refusal to plot."""

    exit_code = 2


def no_such_file(path, give: str) -> str:
    """The one wording of an input that is not there: ``PATH: no such file; give …``."""
    return f"{path}: no such file; give {give}"
