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
    for path in sorted((ROOT / "pencilbot" / "driver").rglob("*.py")):
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


# --- the house: families, circles, sizes (issue 34) -------------------------------------------

# The driver and the simulator hold one sub-package per plotter family. A module at the package's
# top level is shared by every family and imports none; only the pickers choose one (the driver's
# draw() and open_control(), the ``sim://`` adapter; sim.bulk is the G-code simulator's fast path
# for ``simulate``, kept at the top level while it is rewritten). A family imports another only
# where listed: an EBB board draws a G-code job, read by the G-code family's job reader.
FAMILIES: dict[str, dict[str, set[str]]] = {
    "pencilbot.driver": {"gcode": set(), "ebb": {"gcode"}, "hpgl": set()},
    "sim": {"gcode": set(), "ebb": set(), "hpgl": set()},
}
PICKERS = {"pencilbot.driver.plot", "pencilbot.driver.control", "sim.protocol_sim", "sim.bulk"}
MAX_FILE_LINES = 450
MAX_FUNCTION_LINES = 80
# Functions over MAX_FUNCTION_LINES not yet split, by "path:name" (issue 34). The list only
# shrinks: a function that is split must leave it (the test fails on a stale entry).
LONG_FUNCTIONS: set[str] = set()
# Files over MAX_FILE_LINES not yet split; the same rule.
LONG_FILES: set[str] = set()


def family_of(module: str) -> tuple[str, str | None] | None:
    """``(package, family or None for the shared top level)`` of a driver or simulator module."""
    for package, families in FAMILIES.items():
        if module == package or module.startswith(package + "."):
            rest = module[len(package) + 1 :].split(".")
            return package, rest[0] if rest[0] in families and len(rest) > 1 else None
    return None


def family_violations(root: Path) -> list[str]:
    """Every import between families, or from a shared module into a family, that is not allowed."""
    known = modules(root)
    out = []
    for name, path in known.items():
        here = family_of(name)
        if here is None or name in PICKERS:
            continue
        for line, target in imports(name, path, known):
            there = family_of(target)
            if there is None or there[0] != here[0] or there[1] is None or there[1] == here[1]:
                continue
            if here[1] is None or there[1] not in FAMILIES[here[0]][here[1]]:
                out.append(f"{path.relative_to(root)}:{line}: {name} imports {target}")
    return out


def typing_only(path: Path) -> set[int]:
    """The lines of the imports under ``if TYPE_CHECKING:`` in ``path`` (annotations only: never
    run, so never part of a circle)."""
    lines = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            lines |= {n.lineno for stmt in node.body for n in ast.walk(stmt) if isinstance(n, ast.stmt)}
    return lines


def import_circles(root: Path) -> list[list[str]]:
    """The strongly connected groups of two or more modules in the graph of the imports that run
    (at the top of a module or inside a function), by Tarjan's algorithm."""
    known = modules(root)
    graph = {}
    for name, path in known.items():
        skip = typing_only(path)
        graph[name] = {
            t for line, t in imports(name, path, known) if t in known and t != name and line not in skip
        }
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles = []

    def connect(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in graph[node]:
            if nxt not in index:
                connect(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            group = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                group.append(top)
                if top == node:
                    break
            if len(group) > 1:
                circles.append(sorted(group))

    for node in sorted(graph):
        if node not in index:
            connect(node)
    return circles


def product_files(root: Path) -> list[Path]:
    return [path for package in PACKAGES for path in sorted((root / package).rglob("*.py"))]


def long_functions(root: Path) -> dict[str, int]:
    """``"path:name"`` → lines, for every product function over MAX_FUNCTION_LINES."""
    found = {}
    for path in product_files(root):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_FUNCTION_LINES:
                    found[f"{path.relative_to(root)}:{node.name}"] = lines
    return found


def test_the_families_import_only_the_shared_pieces():
    assert family_violations(ROOT) == []


def test_no_module_imports_itself_round_a_circle():
    assert import_circles(ROOT) == []


def test_no_product_file_runs_over_the_cap():
    long = {
        str(path.relative_to(ROOT)): n
        for path in product_files(ROOT)
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_FILE_LINES
    }
    assert sorted(set(long) - LONG_FILES) == [], long
    assert sorted(LONG_FILES - set(long)) == [], "split: take them off LONG_FILES"


def test_no_product_function_runs_over_the_cap():
    found = long_functions(ROOT)
    assert sorted(set(found) - LONG_FUNCTIONS) == [], found
    assert sorted(LONG_FUNCTIONS - set(found)) == [], "split: take them off LONG_FUNCTIONS"


@pytest.mark.parametrize(
    ("files", "complaint"),
    [
        ({"sim/a.py": "from sim import b\n", "sim/b.py": "def f():\n    from sim import a\n"}, "circle"),
        (
            {
                "sim/a.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from sim import b\n",
                "sim/b.py": "from sim import a\n",
            },
            None,
        ),
        ({"sim/faults.py": "from sim.gcode import planner\n"}, "family"),
        ({"sim/ebb/board.py": "from sim.hpgl.board import HpglBoard\n"}, "family"),
        ({"pencilbot/driver/hpgl/plot.py": "from pencilbot.driver.gcode import job\n"}, "family"),
        ({"pencilbot/driver/journal.py": "from ..driver.gcode.job import Job\n"}, "family"),
        ({"sim/big.py": "x = 1\n" * (MAX_FILE_LINES + 1)}, "file"),
        ({"sim/long.py": "def f():\n" + "    x = 1\n" * MAX_FUNCTION_LINES}, "function"),
    ],
)
def test_the_house_checks_catch_a_broken_house(tmp_path, files, complaint):
    for folder in (
        "pencilbot/driver/gcode",
        "pencilbot/driver/hpgl",
        "sim/gcode",
        "sim/ebb",
        "sim/hpgl",
        "firmware_protocol",
    ):
        for step in range(1, folder.count("/") + 2):
            part = tmp_path / "/".join(folder.split("/")[:step])
            part.mkdir(exist_ok=True)
            (part / "__init__.py").write_text("")
    for name in ("sim/gcode/planner.py", "sim/hpgl/board.py", "pencilbot/driver/gcode/job.py", "sim/b.py"):
        (tmp_path / name).write_text("")
    checks = {
        "circle": lambda: import_circles(tmp_path),
        "family": lambda: family_violations(tmp_path),
        "file": lambda: [
            p for p in product_files(tmp_path) if len(p.read_text().splitlines()) > MAX_FILE_LINES
        ],
        "function": lambda: list(long_functions(tmp_path)),
    }
    assert all(check() == [] for check in checks.values())
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    assert [kind for kind, check in checks.items() if check()] == ([complaint] if complaint else [])


def test_every_package_is_in_the_wheel():
    """pyproject lists the packages by hand: one left out installs without it (an editable
    install hides that; CI's `pip install .` does not)."""
    import tomllib

    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {
        ".".join(init.parent.relative_to(ROOT).parts)
        for top in ("pencilbot", "sim", "firmware_protocol")
        for init in (ROOT / top).rglob("__init__.py")
    }
    assert sorted(found - listed) == [], "add them to [tool.setuptools] packages"
