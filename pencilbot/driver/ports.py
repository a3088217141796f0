"""Which serial ports there are, and which plotter answers on each — without moving anything.

A probe opens the port, listens for a start-up banner (GRBL and Marlin boards on an Arduino
reset when the port opens and greet), then asks each family the one question it answers and
the others shrug off: GRBL ``$I`` (build info), Marlin ``M115`` (firmware info), the EiBotBoard
(AxiDraw, NextDraw, iDraw) ``V`` (version), and — at 9600 bit/s, the RS-232 plotters' speed —
HP-GL ``OI;`` (the model). None of these moves a motor or the pen. The first answer that
matches names the plotter.

The operating system lists USB and built-in serial ports (:func:`list_ports`); pseudo-terminals
(``pencilbot sim-serve``), sockets and ``sim://`` URLs are probed when named.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass

import serial

from pencilbot.driver.port import listened
from pencilbot.errors import PencilbotError
from pencilbot.firmware.base import DEFAULT_BAUD
from pencilbot.firmware.hpgl import HPGL

#: One question per family: (family, bit/s, bytes sent, pattern of the answer; group 1 = version).
PROBES: tuple[tuple[str, int, bytes, re.Pattern], ...] = (
    ("grblHAL", DEFAULT_BAUD, b"", re.compile(r"^GrblHAL\s+(\S+)", re.IGNORECASE)),
    ("GRBL", DEFAULT_BAUD, b"", re.compile(r"^Grbl\s+(\S+)")),
    ("Marlin", DEFAULT_BAUD, b"", re.compile(r"^(?:start|echo:Marlin\s*(\S*))$")),
    ("GRBL", DEFAULT_BAUD, b"\r\n$I\r\n", re.compile(r"^\[VER:([^\]:]+)")),
    ("Marlin", DEFAULT_BAUD, b"\nM115\n", re.compile(r"FIRMWARE_NAME:Marlin\s*(\S*)")),
    (
        "EBB",
        DEFAULT_BAUD,
        b"\rV\r",
        re.compile(r"^(?:EBB\S*\s+)?EB(?:Bot)?\S* Firmware Version\s+(\S+)|^(EBBv\S+)"),
    ),
    ("HP-GL", HPGL.baud, b"\x1b.J;OI;", re.compile(r"^(\d{4}[A-Z]?|DXY-?\S+)$")),
)
#: The end of a GRBL board's $I answer: its ok, or before it grblHAL's own firmware line (a
#: grblHAL whose banner was missed is still told apart from GRBL).
_HAL_OR_OK = re.compile(r"^(ok|\[FIRMWARE:grblHAL\])$")
BANNER_WAIT = 1.5  # s: an Arduino's bootloader, then GRBL's or Marlin's greeting
ANSWER_WAIT = 0.6  # s for one question's answer


@dataclass(frozen=True)
class PortInfo:
    """A port and what answered on it (``plotter`` None: nothing recognisable)."""

    device: str
    description: str = ""
    plotter: str | None = None  # "GRBL", "grblHAL", "Marlin", "EBB", "HP-GL"
    version: str = ""
    answer: str = ""  # the line that named it
    error: str = ""  # why it could not be probed (in use, gone)

    def summary(self) -> str:
        if self.error:
            return self.error
        if self.plotter is None:
            return "no plotter answered"
        return f"{self.plotter} {self.version}".strip() + f" ('{self.answer}')"


def list_ports() -> list[PortInfo]:
    """The serial ports the operating system lists (USB adapters, built-in, Bluetooth)."""
    from serial.tools import list_ports as lp

    return [
        PortInfo(p.device, p.description if p.description != "n/a" else "") for p in sorted(lp.comports())
    ]


def probe(
    device: str, *, description: str = "", banner_wait: float = BANNER_WAIT, answer_wait: float = ANSWER_WAIT
) -> PortInfo:
    """Ask the board on ``device`` what it is (see the module docstring); nothing moves."""
    handle = None
    try:
        for family, baud, question, pattern in PROBES:
            if handle is None or handle.baudrate != baud:
                if handle is not None:
                    handle.close()
                handle = serial.serial_for_url(
                    device, baudrate=baud, timeout=0.02, write_timeout=2, exclusive=True
                )
                lines = _Lines(handle)
            if question:
                lines.drop()
                handle.write(question)
                found = lines.find(pattern, answer_wait)
            else:  # the greeting of a board that reset as the port opened (listened for since)
                found = lines.find(pattern, max(banner_wait - lines.listening, 0.05), keep=True)
            if found is not None:
                text, version = found
                if family == "GRBL" and question:  # $I: grblHAL names itself before the ok
                    end = lines.find(_HAL_OR_OK, answer_wait, start=lines.lines.index(text) + 1)
                    family = "grblHAL" if end is not None and end[1] != "ok" else family
                return PortInfo(device, description, family, version, text)
        return PortInfo(device, description)
    except (serial.SerialException, OSError, ValueError, PencilbotError) as exc:
        busy = "busy" in str(exc).lower() or "lock" in str(exc).lower() or "in use" in str(exc).lower()
        return PortInfo(
            device, description, error="in use by another program" if busy else f"cannot open: {exc}"
        )
    finally:
        if handle is not None:
            try:
                handle.close()
            except Exception:  # noqa: BLE001 - a vanished port may fail to close
                pass


def probe_all(infos: list[PortInfo]) -> list[PortInfo]:
    """:func:`probe` every port, all at once (each waits for its own board), in the given order."""
    from concurrent.futures import ThreadPoolExecutor

    if not infos:
        return []
    with ThreadPoolExecutor(max_workers=min(len(infos), 16)) as pool:
        return list(pool.map(lambda i: probe(i.device, description=i.description), infos))


def find_plotters(devices: list[str] | None = None) -> list[PortInfo]:
    """Probe ``devices`` (default: every listed port); the ports where a plotter answered."""
    infos = [PortInfo(d) for d in devices] if devices else list_ports()
    return [f for f in probe_all(infos) if f.plotter is not None]


class _Lines:
    """Lines (CR or LF ended) from a port, kept so a later pattern can look at earlier lines."""

    def __init__(self, handle):
        self.handle = handle
        self.partial = b""
        self.lines: list[str] = []
        self.listening = 0.0  # s spent in reads that found nothing (a loaded host's stalls are not)

    def drop(self) -> None:
        self._read()
        self.lines.clear()
        self.partial = b""

    def _read(self) -> bool:
        """Whether bytes came (time spent listening counted when none did)."""
        asked = time.monotonic()
        data = self.handle.read(max(self.handle.in_waiting, 1))
        self.listening += 0.0 if data else listened(self.handle, asked)
        if data:
            *done, self.partial = (self.partial + data).replace(b"\r", b"\n").split(b"\n")
            self.lines += [d.decode("ascii", errors="replace").strip() for d in done if d.strip()]
        return bool(data)

    def find(
        self, pattern: re.Pattern, wait: float, keep: bool = False, start: int = 0
    ) -> tuple[str, str] | None:
        """The first line from ``start`` on that ``pattern`` matches, once it came; None after
        ``wait`` s of listening (or 2000 reads of talk without it: a device that talks on)."""
        since, talk = self.listening, 0
        while True:
            for line in self.lines[start:]:
                m = pattern.search(line)
                if m:
                    return line, next((g for g in m.groups() if g), "")
            if self.listening - since >= wait or talk > 2000:
                return None
            talk += self._read()


#: Families whose boards take the same jobs (grblHAL speaks GRBL's protocol).
_KINDS = {"grblHAL": "GRBL"}


def wrong_kind(found: list[PortInfo], profile) -> tuple[list[PortInfo], str]:
    """The plotters among ``found`` that can draw ``profile``'s jobs, and, when some cannot,
    the line that says so."""
    want = _KINDS.get(profile.firmware.title, profile.firmware.title)
    fits = [f for f in found if f.plotter is not None and _KINDS.get(f.plotter, f.plotter) == want]
    others = [f for f in found if f not in fits]
    if not others:
        return fits, ""
    named = "; ".join(f"{f.device}: {f.summary()}" for f in others)
    return fits, (
        f"--port auto: no {profile.firmware.title} plotter answered for profile {profile.name}, only "
        f"plotters of another kind ({named}); connect the {profile.firmware.title} plotter, or draw for "
        f"the one found with its own profile and --port"
    )
