"""The plotter profile a G-code file was made for, read from the header `pencilbot export` writes.

A file exported for one plotter and drawn with another's profile goes wrong in ways that show
late: a Z pen sent servo commands cannot lift, a resume restores the wrong pen. So ``draw`` takes
the profile from the file when none is given, and refuses a ``--profile`` that is not the file's.
The header's first lines are ::

    ; pencilbot G-code for grbl-z-a3 (grbl)
    ; source: photo.jpg
    ; profile: plotters/grbl-z-a3.toml

(``profile:`` is where the profile was read from: a shipped one's place in the package, or the
user's own TOML file.)
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from pencilbot.errors import ProfileError, RefusedError
from pencilbot.machine.profile import load_profile

_HEAD_LINES = 12  # the header comes first; a file without one in its first lines has none
_MADE_FOR = re.compile(r"^; pencilbot G-code for (?P<name>\S+) \((?P<dialect>[^)]*)\)\s*$")
_SOURCE = re.compile(r"^; profile: (?P<source>.+?)\s*$")
_ESTIMATE = re.compile(r"^; estimated time: \S+ \((?P<seconds>\d+) s\)\s*$")


@dataclass(frozen=True)
class MadeFor:
    """The profile named in a file's header: its ``name``, where it was read from (``source``,
    None if not in the header), and the header line that names it (1-based)."""

    name: str
    source: str | None
    line: int

    def argument(self) -> str:
        """What to load: the user's own TOML file if it is here and is the named profile, else the name."""
        if self.source and self.source.endswith(".toml") and Path(self.source).is_file():
            try:
                if load_profile(self.source).name == self.name:
                    return self.source
            except ProfileError:
                pass  # changed or broken since: the name may still be known
        return self.name


def _head(handle):
    """The lines of an open text file, each cut at 4 096 characters: a header line is short, and
    a file of one 300 MB line must not be read whole to find that it has none."""
    while line := handle.readline(4096):
        yield line


def made_for(path: str | Path) -> MadeFor | None:
    """The profile the header of the G-code file ``path`` names, or None (no such header, or
    the file cannot be read: loading the job reports that)."""
    found, source = None, None
    try:
        with open(path, encoding="utf-8", errors="replace") as handle:
            for number, line in zip(range(1, _HEAD_LINES + 1), _head(handle)):
                line = line.lstrip("\ufeff")
                if found is None and (match := _MADE_FOR.match(line)):
                    found = (match["name"], number)
                elif found is not None and (match := _SOURCE.match(line)):
                    source = match["source"]
                    break
    except OSError:
        return None
    return MadeFor(found[0], source, found[1]) if found else None


def estimated_seconds(path: str | Path) -> float | None:
    """The plot time (s) the header of ``path`` estimates (acceleration included), or None."""
    try:
        with open(path, encoding="utf-8", errors="replace") as handle:
            for _, line in zip(range(_HEAD_LINES), _head(handle)):
                if match := _ESTIMATE.match(line):
                    return float(match["seconds"])
    except OSError:
        pass
    return None


def profile_for(path: str | Path, given: str | None, default: str) -> str:
    """The profile to draw the G-code file ``path`` with: ``given`` (``--profile``), which must
    be the one its header names; else the header's; else ``default``.

    Raises
    ------
    PlotError
        ``given`` is not the profile the file was made for, or the header's profile is unknown here.
    """
    header = made_for(path)
    if header is None:
        return given or default
    if given is None:
        chosen = header.argument()
        try:
            load_profile(chosen)
        except ProfileError:
            raise RefusedError(
                f"{path} was made for plotter profile {header.name} (line {header.line} of its header), "
                f"which is not known here; give the profile with --profile NAME|FILE.toml "
                "(see pencilbot export --list-profiles)"
            ) from None
        return chosen
    try:
        name = load_profile(given).name
    except ProfileError as err:
        raise RefusedError(str(err)) from None
    if name != header.name:
        raise RefusedError(
            f"{path} was made for plotter profile {header.name} (line {header.line} of its header), not "
            f"{name}: its pen commands and bed are that plotter's. Leave out --profile (or give "
            f"--profile {header.name}), or export the drawing again for {name}"
        )
    return given
