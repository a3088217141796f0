"""One spelling in identifiers: pencilbot's names say "color", as its API, configs and CLI do
(``Layer.color``, a pen set's ``color = "#rrggbb"``, ``sketch(color=True)``, ``--color``); the
prose (docstrings, comments, messages, help) is British and says "colour"."""

import ast
from pathlib import Path

import pencilbot

PACKAGE = Path(pencilbot.__file__).parent


def identifiers(source: str):
    """``(line, name)`` of every name the code binds or uses: variables, arguments, keywords,
    attributes, functions, classes and imported modules, also inside f-strings. Strings,
    docstrings and comments are not names."""
    for node in ast.walk(ast.parse(source)):
        line = getattr(node, "lineno", 0)
        if isinstance(node, ast.Name):
            yield line, node.id
        elif isinstance(node, ast.Attribute):
            yield line, node.attr
        elif isinstance(node, ast.arg):
            yield line, node.arg
        elif isinstance(node, ast.keyword) and node.arg:
            yield line, node.arg
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            yield line, node.name
        elif isinstance(node, ast.alias):
            yield line, node.name
            if node.asname:
                yield line, node.asname
        elif isinstance(node, ast.ImportFrom) and node.module:
            yield line, node.module
        elif isinstance(node, (ast.Global, ast.Nonlocal)):
            yield from ((line, name) for name in node.names)


def test_the_scan_reads_names_and_never_strings_or_comments():
    source = 'from a.colour import b as colours\ncolour_x = f"colour {y.colour}"  # colour\ndef f(colour=1): g(colour=2)\n'
    assert sorted(name for _, name in identifiers(source) if "colour" in name) == [
        "a.colour",
        "colour",
        "colour",
        "colour",
        "colour_x",
        "colours",
    ]


def test_identifiers_in_pencilbot_spell_color_one_way():
    files = sorted(PACKAGE.rglob("*.py"))
    names = [(path, line, name) for path in files for line, name in identifiers(path.read_text())]
    assert sum("color" in name.lower() for _, _, name in names) > 50  # the scan sees the package's names
    other = [
        f"{path.relative_to(PACKAGE.parent)}:{line}: {name}"
        for path, line, name in names
        if "colour" in name.lower()
    ]
    other += [
        str(path.relative_to(PACKAGE.parent)) for path in PACKAGE.rglob("*") if "colour" in path.name.lower()
    ]
    assert not other, "identifiers say color (docs/architecture.md, Names):\n" + "\n".join(other)
