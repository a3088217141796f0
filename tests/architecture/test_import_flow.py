"""The import graph follows the data flow of docs/architecture.md: no upward arrow, no cycle.

A small checker reads every module of the project's packages (``pencilbot``, ``firmware_protocol``,
``sim``) with :mod:`ast`, resolves each import, even one inside a function, to the component it
reaches, and fails on any import that the table below does not allow. The table is the
architecture: change it only together with docs/architecture.md.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("pencilbot", "firmware_protocol", "sim")

BASE = {"pencilbot.errors", "pencilbot.units", "pencilbot.paths", "pencilbot.colors"}
# component → the components it may import (besides itself)
ALLOWED: dict[str, set[str]] = {
    "firmware_protocol": set(),
    "pencilbot.errors": set(),
    "pencilbot.units": set(),
    "pencilbot.paths": set(),
    "pencilbot.colors": set(),
    "pencilbot.fileio": {"pencilbot.errors"},
    "pencilbot.configs_io": {"pencilbot.errors", "pencilbot.fileio"},  # (files read bounded)
    "pencilbot.schema": {"pencilbot.errors"},
    "pencilbot.render": BASE | {"pencilbot.fileio"},
    "pencilbot.imaging": BASE | {"pencilbot.fileio"},
    "pencilbot.firmware": {"firmware_protocol"} | BASE,
    "pencilbot.machine": {"pencilbot.firmware", "pencilbot.configs_io", "pencilbot.schema"} | BASE,
    "pencilbot.planning": {
        "pencilbot.imaging",
        "pencilbot.render",
        "pencilbot.machine",
        "pencilbot.configs_io",
        "pencilbot.schema",
        "pencilbot.fileio",
    }
    | BASE,
    "pencilbot.export": {"pencilbot.planning", "pencilbot.machine", "pencilbot.firmware", "pencilbot.fileio"}
    | BASE,
    "pencilbot.driver": {"pencilbot.firmware", "firmware_protocol", "pencilbot.machine", "pencilbot.fileio"}
    | BASE,
    "sim": {
        "firmware_protocol",
        "pencilbot.firmware",
        "pencilbot.machine",
        "pencilbot.render",
        "pencilbot.fileio",
    }
    | BASE,
}
# The application layer: photo → plan → program for every front door, with the guards; it uses
# planning and export and what they stand on, never the driver, the simulator or a front end.
ALLOWED["pencilbot.app"] = {
    "pencilbot.planning",
    "pencilbot.export",
    "pencilbot.imaging",
    "pencilbot.render",
    "pencilbot.machine",
    "pencilbot.firmware",
    "pencilbot.configs_io",
    "pencilbot.schema",
    "pencilbot.fileio",
} | BASE
# The front ends may use everything below them; nothing below may use them.
_BELOW = set(ALLOWED)
ALLOWED["pencilbot.api"] = _BELOW
ALLOWED["pencilbot.studio"] = _BELOW | {"pencilbot.api", "pencilbot"}  # the web page: the library API, no CLI
ALLOWED["pencilbot.commands"] = _BELOW | {"pencilbot.api", "pencilbot", "pencilbot.studio"}
ALLOWED["pencilbot.vpype_plugin"] = _BELOW  # a front end too: through the application layer, no CLI
ALLOWED["pencilbot.cli"] = {"pencilbot.commands", "pencilbot"} | BASE
ALLOWED["pencilbot"] = {"pencilbot.api"}  # the package itself: the lazy library API


def component(module: str) -> str | None:
    """The component a project module belongs to (None: not the project's)."""
    parts = module.split(".")
    if parts[0] not in PACKAGES:
        return None
    if parts[0] != "pencilbot":
        return parts[0]
    if len(parts) == 1:
        return "pencilbot"
    return f"pencilbot.{parts[1]}"


def modules(root: Path) -> dict[str, Path]:
    """Module name → file, for every module of the project's packages under ``root``."""
    found = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            found[".".join(parts)] = path
    return found


def imports(name: str, path: Path, known: dict[str, Path]) -> list[tuple[int, str]]:
    """``(line, module)`` for every project module ``name`` imports, anywhere in the file."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                found.append((node.lineno, sub if sub in known else base))
    return [(line, module) for line, module in found if component(module) is not None]


def violations(root: Path) -> list[str]:
    """Every import under ``root`` that runs against the allowed flow, in words."""
    known = modules(root)
    out = []
    for name, path in known.items():
        source = component(name)
        for line, target in imports(name, path, known):
            reached = component(target)
            if reached != source and reached not in ALLOWED.get(source, set()):
                out.append(f"{path.relative_to(root)}:{line}: {source} imports {target} ({reached})")
    return out


def test_the_project_imports_only_along_the_flow():
    assert violations(ROOT) == []


def test_the_allowed_flow_has_no_cycle():
    state: dict[str, str] = {}

    def visit(node: str, trail: tuple[str, ...]) -> None:
        if state.get(node) == "done":
            return
        assert state.get(node) != "open", f"cycle: {' -> '.join(trail + (node,))}"
        state[node] = "open"
        for nxt in ALLOWED.get(node, ()):
            visit(nxt, trail + (node,))
        state[node] = "done"

    for node in ALLOWED:
        visit(node, ())


def test_every_component_of_the_project_is_in_the_table():
    assert {component(name) for name in modules(ROOT)} <= set(ALLOWED)


@pytest.mark.parametrize(
    ("module", "source", "complaint"),
    [
        (
            "pencilbot/planning/bad.py",
            "from pencilbot.export.gcode import write_gcode\n",
            "pencilbot.planning imports",
        ),
        ("firmware_protocol/bad.py", "from pencilbot.errors import PlotError\n", "firmware_protocol imports"),
        ("pencilbot/driver/bad.py", "def f():\n    import sim\n", "pencilbot.driver imports sim"),
        (
            "pencilbot/machine/bad.py",
            "from ..planning import plan\n",
            "pencilbot.machine imports pencilbot.planning.plan",
        ),
        ("sim/bad.py", "from pencilbot import driver\n", "sim imports pencilbot.driver"),
        (
            "pencilbot/vpype_plugin.py",
            "from pencilbot.commands.common import plan_for_input\n",
            "pencilbot.vpype_plugin imports pencilbot.commands",
        ),
        (
            "pencilbot/app/bad.py",
            "from pencilbot.driver import draw\n",
            "pencilbot.app imports pencilbot.driver",
        ),
        (
            "pencilbot/planning/bad.py",
            "from pencilbot.app.photo import prepare\n",
            "pencilbot.planning imports pencilbot.app",
        ),
    ],
)
def test_the_checker_catches_an_import_against_the_flow(tmp_path, module, source, complaint):
    for package in PACKAGES:
        for sub in (
            ("", "/planning", "/export", "/driver", "/machine", "/errors", "/app", "/commands")
            if package == "pencilbot"
            else ("",)
        ):
            (tmp_path / f"{package}{sub}").mkdir(parents=True, exist_ok=True)
            (tmp_path / f"{package}{sub}" / "__init__.py").write_text("")
    (tmp_path / "pencilbot/planning/plan.py").write_text("")
    (tmp_path / "pencilbot/export/gcode.py").write_text("")
    (tmp_path / "pencilbot/app/photo.py").write_text("")
    (tmp_path / "pencilbot/commands/common.py").write_text("")
    assert violations(tmp_path) == []
    (tmp_path / module).write_text(source)
    found = violations(tmp_path)
    assert len(found) == 1 and complaint in found[0] and module in found[0]


def test_the_firmware_neutral_driver_speaks_no_firmware_s_words():
    """Homing, setting an origin and jogging are asked of the firmware registry (issue 20): a GRBL
    command written in the driver would be sent to an EBB, HP-GL or Marlin board too."""
    commands = ("$H", "$J=", "G10L20")
    found = []
    for path in sorted((ROOT / "pencilbot" / "driver").glob("*.py")):
        tree = ast.parse(path.read_text())
        docstrings = {
            id(node.body[0].value)
            for node in ast.walk(tree)
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef))
            and node.body
            and isinstance(node.body[0], ast.Expr)
            and isinstance(node.body[0].value, ast.Constant)
        }
        found += [
            f"{path.relative_to(ROOT)}:{node.lineno}: {node.value!r}"
            for node in ast.walk(tree)
            if isinstance(node, ast.Constant)
            and isinstance(node.value, str)
            and id(node) not in docstrings
            and any(word in node.value.replace(" ", "") for word in commands)
        ]
    assert not found, "firmware commands in the driver:\n" + "\n".join(found)
