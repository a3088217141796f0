"""At the plotter: raise, lower and read back the pen, try pen heights, switch the motors off and
on, walk the carriage, home it — on every firmware of the registry, as AxiDraw's ``axicli``
manual commands do.

:func:`open_control` opens the port and gives the :class:`Control` the profile's firmware needs:
a board that acknowledges lines (GRBL, grblHAL, Marlin) is told G-code through a
:class:`~pencilbot.driver.gcode.session.BoardSession`, an EBB board step and servo commands through an
:class:`~pencilbot.driver.ebb.link.EbbLink` (:mod:`pencilbot.driver.ebb.control`), an HP-GL
plotter instructions with ``OA;`` as the answer of where its pen is
(:mod:`pencilbot.driver.hpgl.control`). What a firmware cannot do is one :class:`PlotError`
that says so and what to do instead.

Example
-------
>>> with open_control("sim://a", "axidraw-v3") as plotter:   # doctest: +SKIP
...     plotter.pen("toggle")          # True: the board reports the pen down
...     plotter.walk(10, 0)            # (10.0, 0.0): mm from home
"""

from __future__ import annotations

from pencilbot.driver.control_base import PEN_ACTIONS, Control
from pencilbot.driver.ebb.control import EbbControl
from pencilbot.driver.gcode.control import GcodeControl
from pencilbot.driver.hpgl.control import HpglControl
from pencilbot.driver.port import DEFAULT_TIMEOUT
from pencilbot.machine.profile import Profile, load_profile

__all__ = ["PEN_ACTIONS", "Control", "open_control"]


def open_control(
    port: str, profile: str | Profile, *, baud: int | None = None, timeout: float = DEFAULT_TIMEOUT
) -> Control:
    """Open ``port`` for the plotter of ``profile`` (a name, a .toml path or a :class:`Profile`).

    Raises
    ------
    PlotError
        The port cannot be opened, or no board of the profile's firmware answers on it.
    """
    plotter = profile if isinstance(profile, Profile) else load_profile(profile)
    name = (
        profile.source if isinstance(profile, Profile) and profile.source.endswith(".toml") else plotter.name
    )
    fw = plotter.firmware
    baud = baud or fw.baud
    if fw.capabilities.host_motion:
        return EbbControl(plotter, port, name, baud, timeout)
    if fw.flow == "polled":
        return HpglControl(plotter, port, name, baud, timeout)
    return GcodeControl(plotter, port, name, baud, timeout)
