"""A plan's program for a plotter, in the language its firmware reads (``program_language``):
G-code for GRBL, grblHAL, Marlin and EBB boards, HP-GL for an HP-GL plotter. The front doors ask
here instead of testing the firmware themselves."""

from __future__ import annotations

from pathlib import Path

from pencilbot.export.gcode import GCODE_SUFFIXES, GcodeSummary, write_gcode
from pencilbot.export.hpgl import HPGL_SUFFIXES, HpglSummary, write_hpgl
from pencilbot.machine.profile import Profile
from pencilbot.planning.plan import Plan


def speaks_hpgl(profile: Profile) -> bool:
    """Whether ``profile``'s plotter reads HP-GL (else G-code)."""
    return profile.firmware.program_language == "hpgl"


def program_suffixes(profile: Profile) -> tuple[str, ...]:
    """The names ``profile``'s programs go by, the usual one first: ``.hpgl`` … or ``.gcode`` …"""
    return HPGL_SUFFIXES if speaks_hpgl(profile) else GCODE_SUFFIXES


def write_program(
    plan: Plan, profile: Profile, path: str | Path, *, source: str = ""
) -> GcodeSummary | HpglSummary:
    """Write ``plan``'s program for ``profile`` to ``path`` atomically (HP-GL for an HP-GL
    plotter, else G-code naming ``source`` in its header); its summary (``.stats`` the estimate)."""
    if speaks_hpgl(profile):
        return write_hpgl(plan, profile, path)
    return write_gcode(plan, profile, path, source=source)
