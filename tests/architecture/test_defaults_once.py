"""Each default is said once: a function or field that takes one of the shared settings gets its
default from the constant that owns it, never from a literal written again.

The keys (pen width, hatch angles / coverage / overlap, dpi, baud, timeout, CSS pixels per inch,
millimetres per inch) were each written in several places once, and drifted apart (an onset
overlap of 0.5 beside the style's 0.25). This test reads the product's source and fails when a
literal comes back.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PRODUCT = sorted(p for d in ("pencilbot", "sim") for p in (ROOT / d).rglob("*.py"))

#: Parameters and fields whose default must name a constant, not repeat a number.
SHARED_SETTINGS = {
    "pen_width",
    "travel_pen",
    "angles",
    "hatch_angles",
    "coverage",
    "hatch_coverage",
    "overlap",
    "dpi",
    "baud",
    "baudrate",
    "timeout",
    "order_rounds",
}
#: Where each shared constant is defined: the one place.
HOMES = {
    "DEFAULT_PEN_WIDTH": "pencilbot/units.py",
    "MM_PER_INCH": "pencilbot/units.py",
    "CSS_PX_PER_INCH": "pencilbot/units.py",
    "DEFAULT_DPI": "pencilbot/render/canvas.py",
    "DEFAULT_TIMEOUT": "pencilbot/driver/port.py",
    "HATCH_ANGLES": "pencilbot/planning/hatching.py",
    "HATCH_COVERAGE": "pencilbot/planning/hatching.py",
    "HATCH_OVERLAP": "pencilbot/planning/hatching.py",
    "DEFAULT_ROUNDS": "pencilbot/planning/ordering.py",
    "DEFAULT_BAUD": "pencilbot/firmware/base.py",
}
#: Numbers that only their home may write: baud, CSS px per inch, mm per inch.
HOME_OF_NUMBER = {115200: "pencilbot/firmware/base.py", 96: "pencilbot/units.py", 25.4: "pencilbot/units.py"}


@functools.cache
def _trees():
    """Every product file parsed, once for the module's tests (the source does not change under them)."""
    return [(path.relative_to(ROOT).as_posix(), ast.parse(path.read_text(), str(path))) for path in PRODUCT]


def _number(node) -> bool:
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        node = node.operand
    return isinstance(node, ast.Constant) and type(node.value) in (int, float)


def _literal(node) -> bool:
    """A number other than 0 (0 means "none", not a setting), or a tuple of numbers: a default
    written out."""
    if _number(node):
        return ast.literal_eval(node) != 0
    return isinstance(node, ast.Tuple) and bool(node.elts) and all(_number(e) for e in node.elts)


def _defaults(tree):
    """(name, default node, line) of every parameter default and class-level annotated field."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            args = node.args
            positional = args.posonlyargs + args.args
            yield from (
                (a.arg, d, d.lineno)
                for a, d in zip(positional[len(positional) - len(args.defaults) :], args.defaults)
            )
            yield from (
                (a.arg, d, d.lineno) for a, d in zip(args.kwonlyargs, args.kw_defaults) if d is not None
            )
        elif isinstance(node, ast.ClassDef):
            for item in node.body:
                if (
                    isinstance(item, ast.AnnAssign)
                    and isinstance(item.target, ast.Name)
                    and item.value is not None
                ):
                    yield item.target.id, item.value, item.lineno


def test_shared_settings_take_their_default_from_the_constant():
    repeated = [
        f"{path}:{line}: {name} = {ast.unparse(default)}"
        for path, tree in _trees()
        for name, default, line in _defaults(tree)
        if name in SHARED_SETTINGS and _literal(default)
    ]
    assert not repeated, "defaults written again instead of named:\n" + "\n".join(repeated)


@pytest.mark.parametrize("name", sorted(HOMES))
def test_each_shared_constant_is_defined_once_in_its_home(name):
    defined = sorted(
        path
        for path, tree in _trees()
        for node in ast.walk(tree)
        if isinstance(node, ast.Assign)
        and any(isinstance(t, ast.Name) and t.id == name for t in node.targets)
    )
    assert defined == [HOMES[name]]


def test_shared_numbers_are_written_only_in_their_home():
    stray = [
        f"{path}:{node.lineno}: {node.value!r}"
        for path, tree in _trees()
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant)
        and type(node.value) in (int, float)
        and node.value in HOME_OF_NUMBER
        and HOME_OF_NUMBER[node.value] != path
    ]
    assert not stray, "a shared number written outside its home:\n" + "\n".join(stray)


def test_the_checks_see_a_repeated_default():
    """The scanner itself: a literal default is caught, a named one is not."""
    tree = ast.parse("def f(pen_width=0.5, dpi=DEFAULT_DPI, angles=(0.0, 90.0)):\n    pass\n")
    caught = [name for name, default, _ in _defaults(tree) if name in SHARED_SETTINGS and _literal(default)]
    assert caught == ["pen_width", "angles"]
