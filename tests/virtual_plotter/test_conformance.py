"""The virtual GRBL answers every row of the GRBL 1.1h conformance table byte for byte.

The table (``grbl_conformance.tsv`` beside this file) is data: bytes sent to a board in a named
starting state, the exact bytes real GRBL 1.1h answers, and where in GRBL's source that answer
is decided. This module only builds the boards and replays the rows.
"""

import codecs
import re
from pathlib import Path

import pytest
from machines import description

from sim.gcode.firmware import Firmware
from sim.gcode.machine import Machine

TABLE = Path(__file__).with_name("grbl_conformance.tsv")
_DIRECTIVE = re.compile(r"\{(poll [0-9.]+|power)\}")


def _unescape(text: str) -> str:
    return codecs.decode(text, "unicode_escape")


def read_table(path: Path = TABLE) -> tuple[list[tuple[int, str, str, str, str]], dict[str, str]]:
    """``(rows, macros)``: rows as (line number, board, sent, reply, source), escapes kept."""
    rows, macros = [], {}
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if not line or line.startswith(("#", "board\t")):
            continue
        fields = line.split("\t")
        if line.startswith("@"):
            macros[fields[0][1:]] = fields[1]
            continue
        assert len(fields) == 4, f"{path.name}:{number}: expected 4 tab-separated fields"
        rows.append((number, *fields))
    return rows, macros


ROWS, MACROS = read_table()


def expand(text: str) -> str:
    """Macros replaced (repeatedly: a macro may use another); directives left in place."""
    for _ in range(5):
        text = re.sub(r"\{([A-Z0-9_]+)\}", lambda m: MACROS[m.group(1)], text)
    return text


def board(name: str) -> Firmware:
    """A board in the table's named starting state, its power-up output taken."""
    homing = name in ("homing", "homed")
    machine = Machine(description(homing=homing, soft_limits=homing), instant=name != "realtime")
    fw = Firmware(machine, power_zero=name == "power-zero")
    if name == "homed":
        fw.receive(b"$H\n")
    fw.take_output()
    return fw


def replay(fw: Firmware, sent: str) -> bytes:
    """Send ``sent`` (escapes decoded, ``{poll S}`` / ``{power}`` acted on); all the board said."""
    out = b""
    for i, part in enumerate(_DIRECTIVE.split(sent)):
        if i % 2 == 0:
            fw.receive(_unescape(part).encode("latin-1"))
        elif part == "power":
            fw.power_cycle()
        else:
            fw.poll(float(part.split()[1]))
        out += fw.take_output()
    return out


@pytest.mark.parametrize(
    "number, name, sent, reply, source", ROWS, ids=[f"L{r[0]}:{r[2][:30]}" for r in ROWS]
)
def test_row(number, name, sent, reply, source):
    got = replay(board(name), expand(sent)).decode("latin-1")
    assert got == _unescape(expand(reply)), f"{TABLE.name}:{number} ({source})"


# Every difference issue 12 measured against a real GRBL 1.1h board has a row.
ISSUE_CASES = [
    "G2 X0 Y0 R5 F100",
    "G2 X10 F100",
    "G2 F100",
    "G2 Z5 F100",
    "G2 X10 R5 I5 F100",
    "G38.2 F100",
    "G10 L2 P7 X1",
    "G0 G1 X1",
    "G93 G1 X10",
    "$J=X10",
    "$J=X10 F100 S100",
    "M280 P0 S90",
    "M7",
    "$H",
    "$20=1",
    "$$",
    "Pn:",
    "[G28:",
    "[G30:",
    "[VER:1.1h.20190825:",
    "$RST=$",
    "G17 G40 G49 G61 G91.1",
    "G43.1 Z1",
    "G55",
    "G18",
    "G19",
    "G93 G1 X10 F100",
    "G28.1",
    "G30.1",
    "G30",
    "G53",
    "G10 L2",
    "G10 L20",
    "$N0=",
    "$I=",
    "$J=G53 X10 F100",
    "$J=X10 F100 N10",
    "%",
    "\\xef\\xbb\\xbf",
    "M0",
    "M2",
    "M30",
]


@pytest.mark.parametrize("case", ISSUE_CASES)
def test_every_case_of_issue_12_is_in_the_table(case):
    assert any(case in sent or case in expand(reply) for _, _, sent, reply, _ in ROWS), case


def test_every_row_names_its_source_in_grbl():
    files = (
        "gcode.c",
        "protocol.c",
        "system.c",
        "settings.c",
        "report.c",
        "motion_control.c",
        "serial.c",
        "main.c",
        "limits.c",
        "jog.c",
        "spindle_control.c",
    )
    assert all(any(f in source for f in files) for *_, source in ROWS)
    assert len(ROWS) >= 200
