"""The fast path's reading of plain G-code (:mod:`sim.bulk`): a block of lines as whole arrays.

A block's text is filtered as GRBL's protocol loop filters a line (``;`` comments and white space
dropped, upper case), then read over its bytes at once: every letter starts a word, whose number
is the run of digits, dots and signs after it up to the next letter or the line's end. Each word
gets a kind (a motion ``G0``/``G1``, an axis, a feed, a spindle ``M3``/``M4``/``M5``, ``S``, a
dwell ``G4``, ``P``, a header mode ``G21 G90 G94 G17``), and each line one of the plain forms
(``[G0|G1] [X] [Y] [Z] [F]`` in that order, ``M3|M4|M5 [S]``, ``G4 P``, one header mode), else it
is of another form: the fast path stops there and the full interpreter takes the job.

Numbers are read as ``float()`` reads them (and GRBL's read_float, for at most 8 digits): the
digits as one integer (exact below 2**53) divided by a power of ten (exact up to 10**22), one
correctly rounded division, which is the decimal number correctly rounded. A number of more
than 8 digits, which GRBL reads otherwise, is another form.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from firmware_protocol import grbl

#: Bytes a plain job's lines are made of (after ``;`` comments): anything else (parentheses,
#: realtime bytes, ``$``, ``%``, ``/``, a lone ``\r``, non-ASCII) is another form.
_PLAIN_BYTES = re.compile(rb"[^A-Za-z0-9.+\- \t\n]")
_COMMENT = re.compile(rb";[^\n]*")
_SPACES = bytes(b for b in grbl.DROPPED_BYTES if b != ord("\n"))
_MAX_DIGITS = 8  # read_float's significant digits
#: 10**k as floats, exact for every k here.
_POW10 = np.array([float(10**k) for k in range(23)])

# Word kinds, the move words in their order on a line.
MOTION, X, Y, Z, F, SPINDLE, S, DWELL, P, MODE, OTHER = range(11)
# Line forms.
BLANK, MOVE, SPINDLE_LINE, DWELL_LINE, MODE_LINE = range(5)


@dataclass(frozen=True)
class Lines:
    """A block's plain lines, up to the first of another form (``count`` of them), each as arrays
    indexed by line. ``other``: whether a line of another form ends them (at index ``count``)."""

    count: int
    other: bool
    form: np.ndarray  # BLANK, MOVE, SPINDLE_LINE, DWELL_LINE or MODE_LINE
    motion: np.ndarray  # G0 / G1 on the line (0 or 1), else -1
    has_axis: np.ndarray  # (count, 3) X, Y, Z given
    axis: np.ndarray  # (count, 3) their values
    has_feed: np.ndarray
    feed: np.ndarray
    spindle: np.ndarray  # 3, 4 or 5 on a spindle line, else 0
    has_speed: np.ndarray
    speed: np.ndarray
    dwell: np.ndarray  # P (s) of a G4 line


def read_lines(block: bytes) -> Lines:
    """The plain lines of ``block`` (whole lines; the last may lack its ``\\n``)."""
    if not block.endswith(b"\n"):
        block += b"\n"
    if b"\r" in block:
        block = block.replace(b"\r\n", b"\n")  # a lone \r ends a line too: another form
    if b";" in block:
        block = _COMMENT.sub(b"", block)
    foreign = _PLAIN_BYTES.search(block)
    if foreign is not None:  # read up to the line it is on
        block = block[: block.rfind(b"\n", 0, foreign.start()) + 1]
    text = np.frombuffer(block.translate(None, _SPACES).upper(), np.uint8)
    newlines = np.flatnonzero(text == 10)
    letters = np.flatnonzero((text >= 65) & (text <= 90))
    line = np.searchsorted(newlines, letters)  # each word's line
    words = _words(text, letters, np.minimum(np.append(letters[1:], len(text)), newlines[line]))
    kind = _kinds(text[letters], *words)
    count = _first_other(text, newlines, line, kind)
    keep = line < count
    lines = _by_line(count, line[keep], kind[keep], words[0][keep])
    return Lines(count, foreign is not None or count < len(newlines), *lines)


def _words(text: np.ndarray, letters: np.ndarray, ends: np.ndarray):
    """Each word's number (its characters from after the letter to ``ends``): its value, digit
    count, whether it has a sign (first, as a number's sign must be), and whether it is a number
    at all (at least one digit, at most one dot and one sign)."""
    first = letters + 1
    digit = (text >= 48) & (text <= 57)
    dot, sign = text == 46, (text == 43) | (text == 45)
    counts = [np.concatenate([[0], np.cumsum(mask)]) for mask in (digit, dot, sign)]
    digits, dots, signs = (c[ends] - c[first] for c in counts)
    signed = np.isin(text[np.minimum(first, len(text) - 1)], (43, 45)) & (first < ends)
    number = (digits >= 1) & (dots <= 1) & (signs <= signed)
    # The digits as one integer: each digit times ten to the number of digits after it in its word.
    at = np.flatnonzero(digit)
    word = np.searchsorted(letters, at, side="right") - 1
    inside = (word >= 0) & (at < ends[np.maximum(word, 0)])
    at, word = at[inside], word[inside]
    after = np.minimum(counts[0][ends[word]] - counts[0][at] - 1, len(_POW10) - 1)
    whole = np.bincount(word, (text[at] - 48) * _POW10[after], minlength=len(letters))
    # Divided by ten to the number of digits after the dot.
    at = np.flatnonzero(dot)
    word = np.searchsorted(letters, at, side="right") - 1
    inside = (word >= 0) & (at < ends[np.maximum(word, 0)])
    at, word = at[inside], word[inside]
    fraction = np.zeros(len(letters), np.int64)
    fraction[word] = np.minimum(counts[0][ends[word]] - counts[0][at], len(_POW10) - 1)
    value = whole / _POW10[fraction]
    value[signed & (text[np.minimum(first, len(text) - 1)] == 45)] *= -1.0
    return value, whole, digits, dots, signed, number


def _kinds(letter, value, whole, digits, dots, signed, number) -> np.ndarray:
    """Each word's kind (OTHER: not one of the plain forms' words, or a number of more than 8 digits)."""
    number = number & (digits <= _MAX_DIGITS)
    unsigned = number & ~signed
    code = unsigned & (dots == 0) & (digits <= 2)  # G and M: 0, 00, 1, 01, …
    kind = np.full(len(letter), OTHER, np.int8)
    g, m = letter == ord("G"), letter == ord("M")
    kind[g & code & (whole <= 1)] = MOTION
    kind[g & code & (whole == 4)] = DWELL
    kind[g & code & (digits == 2) & np.isin(whole, (17, 21, 90, 94))] = MODE
    kind[m & code & np.isin(whole, (3, 4, 5))] = SPINDLE
    for char, k in (("X", X), ("Y", Y), ("Z", Z)):
        kind[(letter == ord(char)) & number] = k
    for char, k in (("F", F), ("S", S), ("P", P)):
        kind[(letter == ord(char)) & unsigned] = k
    return kind


def _first_other(text: np.ndarray, newlines: np.ndarray, line: np.ndarray, kind: np.ndarray) -> int:
    """The index of the first line of another form (the number of lines if none)."""
    starts = np.concatenate([[0], newlines + 1])[: len(newlines)]
    # A line with characters before its first letter (a bare number).
    other = (starts < newlines) & ~((text[starts] >= 65) & (text[starts] <= 90))
    other[line[kind == OTHER]] = True
    # Each word after the first of its line must follow the one before it in one of the forms.
    same = line[1:] == line[:-1]
    before, after = kind[:-1], kind[1:]
    follows = (
        ((before <= F) & (after <= F) & (after > before))
        | ((before == SPINDLE) & (after == S))
        | ((before == DWELL) & (after == P))
    )
    other[line[1:][same & ~follows]] = True
    # A first word that cannot start a line; a G4 without its P.
    opening = np.concatenate([[True], ~same]) if len(line) else np.zeros(0, bool)
    alone = np.concatenate([~same, [True]]) if len(line) else np.zeros(0, bool)
    other[line[opening & np.isin(kind, (S, P))]] = True
    other[line[opening & alone & (kind == DWELL)]] = True
    found = np.flatnonzero(other)
    return int(found[0]) if len(found) else len(newlines)


def _by_line(count: int, line: np.ndarray, kind: np.ndarray, value: np.ndarray) -> tuple:
    """The words' values as arrays indexed by line (lines of the plain forms only)."""
    form = np.zeros(count, np.int8)
    opening = np.concatenate([[True], line[1:] != line[:-1]]) if len(line) else np.zeros(0, bool)
    first = kind[opening]
    form[line[opening]] = np.select(
        [first <= F, first == SPINDLE, first == DWELL], [MOVE, SPINDLE_LINE, DWELL_LINE], MODE_LINE
    )

    def given(k: int) -> tuple[np.ndarray, np.ndarray]:
        has, values = np.zeros(count, bool), np.zeros(count)
        has[line[kind == k]] = True
        values[line[kind == k]] = value[kind == k]
        return has, values

    has_motion, motion = given(MOTION)
    axes = [given(k) for k in (X, Y, Z)]
    has_feed, feed = given(F)
    has_spindle, spindle = given(SPINDLE)
    has_speed, speed = given(S)
    _, dwell = given(P)
    return (
        form,
        np.where(has_motion, motion, -1).astype(np.int8),
        np.stack([a[0] for a in axes], axis=1),
        np.stack([a[1] for a in axes], axis=1),
        has_feed,
        feed,
        np.where(has_spindle, spindle, 0).astype(np.int8),
        has_speed,
        speed,
        dwell,
    )
