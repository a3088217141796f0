"""G-code text in whole arrays: numbers formatted by lookup tables (two gathers, not one
``str()`` a value), fixed-width rows of text, and the rows joined without their padding. What
:mod:`pencilbot.export.gcode` writes a program with."""

from __future__ import annotations

from functools import cache

import numpy as np

from pencilbot.machine.bed import MAX_BED

#: Digits of the largest whole millimetre a coordinate can have (the bed check keeps |x| ≤ MAX_BED).
INT_DIGITS = len(str(MAX_BED))


def number_rows(values: np.ndarray, decimals: int) -> np.ndarray:
    """``values`` (already rounded) as ASCII, up to ``decimals`` digits, trailing zeros dropped.

    A NUL-padded ``(N, 1 + 5 + 1 + decimals)`` byte matrix: sign, integer digits, point and
    fraction. Digits come from lookup tables, so formatting is two gathers, not N str() calls.
    """
    scale = 10**decimals
    n = np.rint(np.abs(values) * scale).astype(np.int64)
    whole, frac = np.divmod(n, scale)
    sign = np.where((values < 0) & (n > 0), ord("-"), 0).astype(np.uint8)
    return np.hstack([sign[:, None], integer_table()[whole], fraction_table(decimals)[frac]])


@cache
def integer_table() -> np.ndarray:
    """Row i: the digits of i (0 ≤ i ≤ MAX_BED) right-aligned, NUL-padded."""
    texts = [f"{i:>{INT_DIGITS}}".replace(" ", "\0") for i in range(MAX_BED + 1)]
    return text_rows(texts, INT_DIGITS, newline=False)


@cache
def fraction_table(decimals: int) -> np.ndarray:
    """Row f: ``"." + f`` as ``decimals`` digits without trailing zeros (nothing for 0)."""
    texts = [f".{f:0{decimals}d}".rstrip("0").rstrip(".") for f in range(10**decimals)]
    return text_rows(texts, decimals + 1, newline=False)


def number_text(value: float, decimals: int) -> str:
    """One value the way :func:`number_rows` writes it (feeds, dwells)."""
    return f"{value:.{decimals}f}".rstrip("0").rstrip(".") if decimals else f"{value:.0f}"


def text_rows(texts: list[str], width: int, *, newline: bool = True) -> np.ndarray:
    """Strings (plus newline) as a NUL-padded ``(len(texts), width)`` byte matrix."""
    blob = "".join(t.ljust(width - newline, "\0") + "\n" * newline for t in texts).encode("ascii")
    return np.frombuffer(blob, dtype=np.uint8).reshape(len(texts), width).copy()


def gather(table: np.ndarray, order: np.ndarray, *, cuts: np.ndarray, inserts: list[str]) -> bytes:
    """The rows ``table[order]`` without their NUL padding, with line ``inserts[i]`` placed
    before row ``cuts[i]`` of ``order``."""
    picked = table[order]
    blob = picked[picked != 0].tobytes()
    lengths = np.count_nonzero(table, axis=1)[order]
    offsets = np.concatenate([[0], np.cumsum(lengths)])[cuts].tolist()
    pieces, start = [], 0
    for offset, line in zip(offsets, inserts):
        pieces += [blob[start:offset], line.encode("ascii") + b"\n"]
        start = offset
    return b"".join([*pieces, blob[start:]])


def ascii_lines(lines: list[str]) -> bytes:
    """Lines as ASCII bytes, each ended by a newline."""
    return "".join(f"{line}\n" for line in lines).encode("ascii")
