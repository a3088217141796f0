"""Many straight shapes of every kind, in several groups and loose, read in whole arrays (all
paths' data as one text, all point lists as another) give what vpype's reader gives: the same
lines, in document order, layer by layer."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pencilbot.errors import PencilbotError
from pencilbot.export import svg_read, svg_straight

_XY = st.tuples(st.integers(0, 9), st.integers(0, 9))


def _path(moves) -> str:
    words = []
    for i, (command, (x, y)) in enumerate(moves):
        command = ("M" if command.isupper() else "m") if i == 0 else command
        words.append(
            {"H": f"H{x}", "h": f"h{x}", "V": f"V{y}", "v": f"v{y}"}.get(command, f"{command}{x},{y}")
        )
    return " ".join(words)


_SHAPE = st.one_of(
    st.lists(
        st.tuples(st.sampled_from(["M", "m", "L", "l", "H", "h", "V", "v"]), _XY), min_size=1, max_size=5
    ).map(lambda moves: f'<path d="{_path(moves)}"/>'),
    st.tuples(st.sampled_from(["polyline", "polygon"]), st.lists(_XY, max_size=4)).map(
        lambda s: f'<{s[0]} points="{" ".join(f"{x},{y}" for x, y in s[1])}"/>'
    ),
    st.tuples(_XY, _XY).map(lambda s: f'<line x1="{s[0][0]}" y1="{s[0][1]}" x2="{s[1][0]}" y2="{s[1][1]}"/>'),
    st.just('<path d=""/>'),
)


def _read(path, straight: bool):
    original = svg_straight.read_straight
    taken = []
    svg_read.read_straight = (
        (lambda *a: taken.append(original(*a)) or taken[-1]) if straight else (lambda *_: None)
    )
    try:
        return svg_read.read_svg(path), taken
    finally:
        svg_read.read_straight = original


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    tops=st.lists(
        st.one_of(_SHAPE, st.lists(_SHAPE, max_size=6).map(lambda s: "<g>" + "".join(s) + "</g>")),
        min_size=1,
        max_size=5,
    )
)
def test_many_shapes_in_groups_read_as_vpype_reads_them(tmp_path, tops):
    body = "".join(tops)
    path = tmp_path / "s.svg"
    path.write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100" '
        f'stroke="black" fill="none">{body}</svg>'
    )
    fast, taken = _read(path, straight=True)
    assert taken and taken[0] is not None  # read in arrays, not by vpype
    slow, _ = _read(path, straight=False)
    assert [layer.name for layer in fast.layers] == [layer.name for layer in slow.layers]
    for a, b in zip(fast.layers, slow.layers):
        assert np.array_equal(a.paths.offsets, b.paths.offsets), body
        assert np.allclose(a.paths.points, b.paths.points, rtol=0, atol=1e-3), body


@pytest.mark.parametrize("d", ["M 1 1 L 2 2 C 3 3 4 4 5 5", "L 1 1", "1 1 L 2 2", "M 1 1 Z l 1 1"])
def test_a_path_the_arrays_do_not_take_sends_the_file_to_vpype(tmp_path, d):
    path = tmp_path / "s.svg"
    path.write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">'
        f'<path d="M 0 0 L 5 5"/><path d="{d}"/></svg>'
    )
    original, taken = svg_straight.read_straight, []
    svg_read.read_straight = lambda *a: taken.append(original(*a)) or taken[-1]
    try:
        svg_read.read_svg(path)
    except PencilbotError as exc:  # vpype may refuse it too: with one message
        assert "vpype cannot read" in str(exc)
    finally:
        svg_read.read_straight = original
    assert taken == [None]


_DECIMAL = st.one_of(
    st.floats(-1e6, 1e6).map(lambda v: f"{v:.{abs(hash(v)) % 9}f}"),
    st.integers(-(10**15), 10**15).map(str),
    st.from_regex(r"[+-]?\.?[0-9]{1,15}", fullmatch=True),
    st.from_regex(r"[0-9eE.+-]{1,6}", fullmatch=True),  # exponents, signs and dots anywhere
    st.sampled_from([w.decode() for w in svg_straight._WORDS]),
)


@given(st.lists(_DECIMAL, min_size=1, max_size=12), st.sampled_from([" ", ",", "\n", "  "]))
def test_numbers_are_strtods_bit_for_bit(words, separator):
    """The column-wise decimal reading gives what numpy's fromstring (strtod) gives, or refuses
    the text just as it does."""
    text = separator.join(words).encode()
    import warnings

    spaced = text.translate(svg_straight._TRANSLATE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            expected = np.fromstring(spaced, dtype=np.float64, sep=" ")
        except ValueError:
            expected = None
    tokens = len(spaced.split())
    if expected is not None and len(expected) != tokens:
        expected = None
    got = svg_straight._numbers(text)
    if expected is None:
        assert got is None
    else:
        assert got is not None and got.tobytes() == expected.tobytes()  # -0.0 too
