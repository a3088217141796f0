"""A profile changed for one run (``draw --speed-down …``, a pen-height trial), and a profile
file's text with one key changed (what a trial keeps in the user's copy).

Every changed value goes through the rule a profile file's value goes through, and the changed
profile through the same cross-checks, so a one-run override can make nothing a file could not.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import replace

from pencilbot.machine.profile import _TABLES, Profile
from pencilbot.machine.profile_checks import check_consistency


def profile_with(
    profile: Profile, changes: Mapping[str, Mapping[str, object]], *, where: str = "command line"
) -> Profile:
    """``profile`` with some keys of its tables changed, e.g. ``{"pen": {"down": 35}}``.

    Raises
    ------
    ProfileError
        A value its rule refuses (named as ``where`` gives it), or a changed profile that is not
        consistent (a pen whose up equals its down, …).
    """
    sections = {}
    for table, values in changes.items():
        if not values:
            continue
        _, rules = _TABLES[table]
        checked = {key: rules[key].apply(value, f"[{table}] {key}", where) for key, value in values.items()}
        sections[table] = replace(getattr(profile, table), **checked)
    if not sections:
        return profile
    changed = replace(profile, **sections)
    check_consistency(changed, where)
    return changed


def toml_with_key(text: str, table: str, key: str, value: object) -> str:
    """TOML ``text`` with ``key = value`` in ``[table]`` (its comment kept), added if absent."""
    literal = f"{value:g}" if isinstance(value, float) else str(value)
    lines = text.splitlines(keepends=True)
    start = next((i for i, line in enumerate(lines) if line.strip() == f"[{table}]"), None)
    if start is None:
        return text.rstrip("\n") + f"\n\n[{table}]\n{key} = {literal}\n"
    end = next((i for i in range(start + 1, len(lines)) if lines[i].lstrip().startswith("[")), len(lines))
    pattern = re.compile(rf"^(\s*{re.escape(key)}\s*=\s*)([^#\n]*?)(\s*(?:#.*)?)$")
    for i in range(start + 1, end):
        found = pattern.match(lines[i].rstrip("\n"))
        if found:
            lines[i] = f"{found.group(1)}{literal}{found.group(3)}\n"
            return "".join(lines)
    lines.insert(start + 1, f"{key} = {literal}\n")
    return "".join(lines)


def pen_unit(profile: Profile) -> str:
    """The unit a profile's pen heights are in."""
    if profile.firmware.capabilities.host_motion:
        return "% of the servo's range"
    return {"spindle": "S values", "z": "mm of Z", "servo": "degrees"}[profile.pen.kind]
