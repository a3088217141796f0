"""GRBL's ``$`` settings on the virtual board: the factory values, a profile's, and ``$x=val``.

The settings are a dict ``{number: value}`` (:attr:`sim.gcode.machine.Machine.settings`, the board's
EEPROM: kept through resets and power cycles).
"""

from __future__ import annotations

import re

from pencilbot.machine.profile import Profile

NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)")  # a number in a ``$`` line, as GRBL reads it
_UINT8_SETTINGS = frozenset({0, 1, 2, 3, 10, 23, 26})
_FLAG_SETTINGS = frozenset({4, 5, 6, 13, 20, 21, 22, 32})

#: GRBL 1.1 factory settings (defaults.h, DEFAULTS_GENERIC); a profile overrides the machine's.
DEFAULT_SETTINGS: dict[int, float] = {
    0: 10,
    1: 25,
    2: 0,
    3: 0,
    4: 0,
    5: 0,
    6: 0,
    10: 1,
    11: 0.010,
    12: 0.002,
    13: 0,
    20: 0,
    21: 0,
    22: 0,
    23: 0,
    24: 25.0,
    25: 500.0,
    26: 250,
    27: 1.0,
    30: 1000,
    31: 0,
    32: 0,
    100: 250.0,
    101: 250.0,
    102: 250.0,
    110: 500.0,
    111: 500.0,
    112: 500.0,
    120: 10.0,
    121: 10.0,
    122: 10.0,
    130: 200.0,
    131: 200.0,
    132: 200.0,
}


def grbl_settings(profile: Profile) -> dict[int, float]:
    """GRBL settings for the machine ``profile`` describes: homing and soft limits as its bed
    says, its rates, acceleration, junction deviation, travel and homing directions."""
    motion, bed, pen = profile.motion, profile.bed, profile.pen_model
    s = dict(DEFAULT_SETTINGS)
    s.update(
        {
            11: motion.junction_deviation,
            20: int(bed.soft_limits),
            22: int(bed.homing),
            110: motion.axis_rate,
            111: motion.axis_rate,
            112: motion.axis_rate,
            120: motion.acceleration,
            121: motion.acceleration,
            122: motion.acceleration,
            130: bed.width,
            131: bed.height,
        }
    )
    # $23 set bits home towards negative: the axes whose machine coordinates grow into the bed.
    s[23] = (0 if bed.invert_x else 1) | (0 if bed.invert_y else 2)
    if pen.kind == "spindle":
        s[30] = max(s[30], pen.up, pen.down)
    return s


def store_setting(machine, line: str) -> int:
    """``$x=val`` (``line``, filtered) into ``machine``'s settings as GRBL's
    settings_store_global_setting; the status code (0: stored)."""
    settings = machine.settings
    key = NUMBER.match(line, 1)
    if key is None:
        return 2
    if line[key.end() : key.end() + 1] != "=":
        return 3
    value_match = NUMBER.match(line, key.end() + 1)
    if value_match is None:
        return 2
    number, value = float(key.group()), float(value_match.group())
    if value_match.end() != len(line) or number > 255:
        return 3
    number = int(number) % 256
    if value < 0:
        return 4
    if number not in settings:
        return 3
    whole = int(value) % 256
    if number == 0 and whole < 3:
        return 6
    if number == 20 and whole and not settings[22]:
        return 10
    if number in _FLAG_SETTINGS:
        settings[number] = 1 if whole else 0
        if number == 22 and not whole:
            settings[20] = 0  # no soft limits without homing
    elif number in _UINT8_SETTINGS:
        settings[number] = whole
    else:
        settings[number] = value
    if number == 13:
        machine.offsets_changed = True
    machine.settings_changed()
    return 0
