"""A block of cleaned G-code lines as arrays of words, read in one pass of numpy: each
well-formed word's line, letter and value (:func:`read_words`), the first value of a letter per
line (:func:`first_value`), the G or M codes per line as bits (:func:`codes`) and the coordinate
system codes (:func:`coordinate_codes`). :mod:`pencilbot.driver.gcode.modal` follows the state
from them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pencilbot.driver.gcode import coords

_LETTER = {letter: ord(letter) - ord("A") for letter in "FGIJLMPRSXYZ"}
MAX_DIGITS = 24  # longer numbers are not G-code: the word is ignored
_JOG_CODES = (20, 21, 53, 90, 91)  # the G codes a GRBL jog takes
_POW10 = 10.0 ** np.arange(-MAX_DIGITS, MAX_DIGITS + 1)  # digit weights by exponent


@dataclass
class Words:
    """Every well-formed word of a block: its line, letter (0 = A) and value, in order; ``jog``:
    the lines that are jogs or homing cycles (their modal words last for the line only)."""

    lines: int
    line: np.ndarray
    letter: np.ndarray
    value: np.ndarray
    jog: np.ndarray


def read_words(block: bytes | bytearray) -> Words:
    a = np.frombuffer(block, dtype=np.uint8)
    newline = a == 10
    breaks = np.flatnonzero(newline)
    n_lines = len(breaks)
    if n_lines == 0:
        return Words(0, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros(0, bool))
    line_of = np.cumsum(newline) - newline  # the line each byte belongs to (its newline too)
    # A '$' line is a system command for the board, not G-code: none of its words count, but for
    # a jog's (``$J=``: its G20/G21/G90/G91/G53 X Y Z F) and a homing cycle's (``$H``: to machine
    # X0 Y0, as G53 G0 X0 Y0 would go). Neither changes the modal state (see ``jog``).
    line_start = np.concatenate([[0], breaks[:-1] + 1])
    system = a[line_start] == ord("$")
    after = np.append(a, [10, 10])  # a line's next two bytes, past the end too
    jogging = system & (after[line_start + 1] == ord("J")) & (after[line_start + 2] == ord("="))
    homing = system & (after[line_start + 1] == ord("H")) & (after[line_start + 2] == 10)
    letter = (a >= 65) & (a <= 90)
    letter[line_start[jogging] + 1] = False  # the J of $J=
    starts = np.flatnonzero(letter & ~(system & ~jogging)[line_of])
    bounds = np.flatnonzero(letter | newline)
    ends = bounds[np.searchsorted(bounds, starts, side="right")]
    # The bytes of each word's number: starts + 1 .. ends - 1, at index ``pos`` within it.
    length = ends - starts - 1
    word = np.repeat(np.arange(len(starts)), length)
    pos = np.arange(int(length.sum())) - np.repeat(np.cumsum(length) - length, length)
    byte = a[np.repeat(starts + 1, length) + pos]
    digit = (byte >= 48) & (byte <= 57)
    dot = byte == 46
    sign = ((byte == 43) | (byte == 45)) & (pos == 0)
    count = len(starts)
    n_dots = np.bincount(word, weights=dot, minlength=count)
    n_digits = np.bincount(word, weights=digit, minlength=count)
    n_bad = np.bincount(word, weights=~(digit | dot | sign), minlength=count)
    ok = (n_digits > 0) & (n_dots <= 1) & (n_bad == 0) & (length <= MAX_DIGITS)
    # A digit is worth 10^(places before the point − 1), or 10^−(places after it).
    point = np.where(n_dots > 0, np.bincount(word, weights=np.where(dot, pos, 0), minlength=count), length)
    point = point.astype(np.int64)[word]
    exponent = np.clip(np.where(pos < point, point - pos - 1, point - pos), -MAX_DIGITS, MAX_DIGITS)
    value = np.bincount(
        word, weights=_POW10[exponent + MAX_DIGITS] * np.where(digit, byte - 48, 0), minlength=count
    )
    negative = np.zeros(count, dtype=bool)
    negative[word[(byte == 45) & (pos == 0)]] = True
    value = np.where(negative, -value, value)
    line, letter, value = line_of[starts][ok], a[starts][ok].astype(np.int64) - 65, value[ok]
    if jogging.any() or homing.any():
        line, letter, value = _jog_words(line, letter, value, jogging, np.flatnonzero(homing))
    return Words(n_lines, line, letter, value, jogging | homing)


def _jog_words(line, letter, value, jogging, homing):
    """The words of a block with jogs and homing cycles: a jog keeps only what GRBL takes in one
    (G20 G21 G90 G91 G53, X Y Z F: anything else the board refuses), a homing line gets
    ``G53 X0 Y0``. The words stay in line order."""
    on_jog = jogging[line]
    takes = np.isin(letter, [_LETTER[c] for c in "GXYZF"]) & ~(
        (letter == _LETTER["G"]) & ~np.isin(value, _JOG_CODES)
    )
    keep = ~on_jog | takes
    line = np.concatenate([line[keep], np.repeat(homing, 3)])
    letter = np.concatenate([letter[keep], np.tile([_LETTER["G"], _LETTER["X"], _LETTER["Y"]], len(homing))])
    value = np.concatenate([value[keep], np.tile([53.0, 0.0, 0.0], len(homing))])
    order = np.argsort(line, kind="stable")
    return line[order], letter[order], value[order]


def first_value(words: Words, letter: str, lines: int) -> np.ndarray:
    """Per line, the value of the first ``letter`` word (NaN where there is none)."""
    pick = words.letter == _LETTER[letter]
    line, value = words.line[pick], words.value[pick]
    first = np.flatnonzero(np.concatenate([[True], line[1:] != line[:-1]])) if len(line) else line
    out = np.full(lines, np.nan)
    out[line[first]] = value[first]
    return out


def codes(words: Words, letter: str, lines: int, bits: np.ndarray) -> np.ndarray:
    """Per line, a mask of the ``<letter><code>`` words it holds: ``bits[code]`` (−1: not read)."""
    code = np.trunc(words.value).astype(np.int64)
    pick = (words.letter == _LETTER[letter]) & (code >= 0) & (code < len(bits))
    bit = bits[code[pick]]
    known = bit >= 0
    mask = np.zeros(lines, dtype=np.int64)
    np.bitwise_or.at(mask, words.line[pick][known], np.left_shift(1, bit[known]))
    return mask


def coordinate_codes(words: Words, lines: int) -> tuple[np.ndarray, np.ndarray]:
    """Per line, its non-modal coordinate code in tenths (:data:`coords.CODES`, 0 for none) and
    the coordinate system it selects (0 = G54 … 5 = G59, −1 for none)."""
    pick = words.letter == _LETTER["G"]
    tenths = np.round(words.value[pick] * 10).astype(np.int64)
    line = words.line[pick]
    code = np.zeros(lines, np.int64)
    known = np.isin(tenths, coords.CODES)
    code[line[known]] = tenths[known]
    select = np.full(lines, -1, np.int64)
    chosen = (tenths >= 540) & (tenths <= 590) & (tenths % 10 == 0)
    select[line[chosen]] = tenths[chosen] // 10 - 54
    return code, select
