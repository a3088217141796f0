"""Mutation testing of the driver, the planner's ordering, hatching and shading, the firmware
grammars and the G-code writer: how many one-token changes the tests catch.

Each mutant is one small change to one module's syntax tree:

``cmp``
    a comparison flipped at its boundary or inverted: ``<`` ↔ ``<=``, ``>`` ↔ ``>=``,
    ``==`` ↔ ``!=``, ``is`` ↔ ``is not``, ``in`` ↔ ``not in``;
``arith``
    an arithmetic sign: ``+`` ↔ ``-`` (binary and augmented), a unary minus dropped;
``const``
    an integer constant ± 1;
``not``
    a condition negated (``if``, ``while``, conditional expressions, ``assert`` excluded) or a
    ``not`` dropped; ``True`` ↔ ``False``;
``boolop``
    ``and`` ↔ ``or``;
``return``
    a returned value dropped (``return x`` → ``return None``).

The tree is copied once per job (``--jobs``) to a temporary folder; for each mutant the mutated
module (``ast.unparse`` of the changed tree) replaces the copy's file, and the module's mapped
fast tests run there in a subprocess with a timeout (``-x``: the first failure kills). The
working tree is never written. A mutant is *killed* when the tests fail or time out.

Survivors that cannot be told apart from the original by any test (an equivalent mutant) are
listed in ``bench/mutants_equivalent.toml`` with a one-line reason; the score is killed over
the non-equivalent mutants run.

Usage::

    python bench/mutants.py --sample 30 --seed 1 --jobs 2            # every module, 30 mutants each
    python bench/mutants.py --module pencilbot/driver/gcode/stream.py --list # the mutants of one module
    python bench/mutants.py --module pencilbot/planning/hatching.py --sample 0   # all of them

Prints JSON: per module killed / total / equivalent / score and every survivor
(``file:line``, operator, the line and the change).
"""

from __future__ import annotations

import argparse
import ast
import copy
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import tomllib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EQUIVALENT = Path(__file__).with_name("mutants_equivalent.toml")
COPIED = ("pencilbot", "firmware_protocol", "sim", "configs", "tests", "pyproject.toml")

_DRIVER_STREAM = [
    "tests/driver/test_receive_buffer_boundary.py",
    "tests/driver/test_stop_reports.py",
    "tests/driver/test_stop_on_a_return_pass.py",
    "tests/driver/test_stream_sim.py",
    "tests/driver/test_marlin_stream.py",
    "tests/driver/test_work_position_board.py",
]
#: Module → the fast tests that cover it (run with -x; the first failure kills).
TESTS: dict[str, list[str]] = {
    "pencilbot/driver/gcode/stream.py": _DRIVER_STREAM,
    "pencilbot/driver/gcode/session.py": _DRIVER_STREAM,
    "pencilbot/driver/plot.py": _DRIVER_STREAM
    + ["tests/driver/test_draw_checks.py", "tests/driver/test_pen_change_draw.py"],
    "pencilbot/driver/gcode/runner.py": _DRIVER_STREAM
    + [
        "tests/driver/test_draw_checks.py",
        "tests/driver/test_pen_change_draw.py",
        "tests/driver/test_progress_listener.py",
        "tests/driver/test_stop_on_a_return_pass.py",
    ],
    "pencilbot/driver/messages.py": [
        "tests/driver/test_stop_reports.py",
        "tests/driver/test_stream_sim.py",
        "tests/driver/test_draw_checks.py",
    ],
    "pencilbot/driver/gcode/resume_point.py": [
        "tests/driver/test_stop_near_a_corner.py",
        "tests/driver/test_work_position_board.py",
        "tests/driver/test_stream_sim.py",
    ],
    "pencilbot/driver/gcode/resume.py": [
        "tests/driver/test_stop_near_a_corner.py",
        "tests/driver/test_modal_resume.py",
        "tests/driver/test_stream_sim.py",
        "tests/driver/test_work_position_board.py",
        "tests/driver/test_stop_on_a_return_pass.py",
    ],
    "pencilbot/driver/gcode/modal.py": [
        "tests/driver/test_modal_codes.py",
        "tests/driver/test_modal_resume.py",
        "tests/driver/test_job.py",
    ],
    "pencilbot/driver/gcode/job.py": [
        "tests/driver/test_job.py",
        "tests/driver/test_modal_resume.py",
        "tests/driver/test_draw_checks.py",
        "tests/driver/test_pen_change_draw.py",
    ],
    "pencilbot/driver/gcode/bed_check.py": [
        "tests/driver/test_draw_checks.py",
        "tests/driver/test_job.py",
        "tests/driver/test_coordinate_systems.py",
    ],
    "pencilbot/driver/gcode/header.py": ["tests/driver/test_draw_checks.py", "tests/driver/test_job.py"],
    "pencilbot/driver/gcode/drawn.py": ["tests/cli/test_cli_stat.py", "tests/driver/test_job.py"],
    "pencilbot/driver/journal.py": [
        "tests/driver/test_journal_input.py",
        "tests/driver/test_journal_progress.py",
        "tests/driver/test_stream_sim.py",
        "tests/driver/test_journal_unwritable.py",
    ],
    "pencilbot/driver/progress.py": ["tests/driver/test_journal_progress.py"],
    "pencilbot/driver/keys.py": ["tests/driver/test_keys.py"],
    "pencilbot/driver/gcode/markers.py": ["tests/driver/test_draw_checks.py", "tests/driver/test_job.py"],
    "pencilbot/driver/port.py": ["tests/driver/test_port_in_use.py", "tests/driver/test_stream_sim.py"],
    "pencilbot/driver/position.py": [
        "tests/driver/test_modal_resume.py",
        "tests/driver/test_stream_sim.py",
        "tests/driver/test_work_position_board.py",
        "tests/driver/test_draw_checks.py",
    ],
    "pencilbot/planning/ordering.py": ["tests/planning/test_ordering.py"],
    "pencilbot/planning/hatching.py": ["tests/planning/test_hatching.py"],
    "pencilbot/planning/shading.py": ["tests/planning/test_hatching.py"],
    "firmware_protocol/grbl.py": [
        "tests/protocol/test_grbl_protocol.py",
        "tests/protocol/test_grblhal_protocol.py",
        "tests/virtual_plotter/test_firmware.py",
    ],
    "firmware_protocol/grblhal.py": [
        "tests/protocol/test_grblhal_protocol.py",
        "tests/virtual_plotter/test_grblhal_front_end.py",
    ],
    "firmware_protocol/marlin.py": [
        "tests/protocol/test_marlin_protocol.py",
        "tests/driver/test_marlin_stream.py",
    ],
    "pencilbot/export/gcode.py": ["tests/export/test_gcode.py", "tests/export/test_pens_export.py"],
}


#: What the score is reported over: the issue's modules, each its files.
GROUPS: dict[str, list[str]] = {
    "driver": [m for m in TESTS if m.startswith("pencilbot/driver/")],
    "planning/ordering": ["pencilbot/planning/ordering.py"],
    "planning/hatching": ["pencilbot/planning/hatching.py"],
    "planning/shading": ["pencilbot/planning/shading.py"],
    "firmware_protocol": [m for m in TESTS if m.startswith("firmware_protocol/")],
    "export/gcode": ["pencilbot/export/gcode.py"],
}


@dataclass(frozen=True)
class Mutant:
    module: str
    number: int  # the n-th mutation point of the module, in tree order
    line: int
    operator: str
    before: str  # the changed expression or statement, as source
    after: str
    text: str = ""  # the source line it is on

    def where(self) -> str:
        return f"{self.module}:{self.line}"


_CMP_SWAP = {
    ast.Lt: ast.LtE,
    ast.LtE: ast.Lt,
    ast.Gt: ast.GtE,
    ast.GtE: ast.Gt,
    ast.Eq: ast.NotEq,
    ast.NotEq: ast.Eq,
    ast.Is: ast.IsNot,
    ast.IsNot: ast.Is,
    ast.In: ast.NotIn,
    ast.NotIn: ast.In,
}
_ARITH_SWAP = {ast.Add: ast.Sub, ast.Sub: ast.Add}


def _skipped(tree: ast.AST) -> set[int]:
    """ids of nodes never mutated: docstrings, annotations, f-string format specs, ``assert``
    statements and ``__future__`` imports."""
    skip: set[int] = set()

    def all_of(node):
        skip.update(id(n) for n in ast.walk(node))

    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (
            isinstance(body, list)
            and body
            and isinstance(body[0], ast.Expr)
            and isinstance(body[0].value, ast.Constant)
        ):
            all_of(body[0])
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            if node.returns is not None:
                all_of(node.returns)
            for arg in [
                *node.args.args,
                *node.args.kwonlyargs,
                *node.args.posonlyargs,
                node.args.vararg,
                node.args.kwarg,
            ]:
                if arg is not None and arg.annotation is not None:
                    all_of(arg.annotation)
        elif isinstance(node, ast.AnnAssign):
            all_of(node.annotation)
        elif isinstance(node, ast.FormattedValue) and node.format_spec is not None:
            all_of(node.format_spec)
        elif isinstance(node, (ast.Assert, ast.ImportFrom, ast.Import)):
            all_of(node)
    return skip


def _points(tree: ast.AST):
    """Every (node, operator, variant) that can be mutated, in a fixed order."""
    skip = _skipped(tree)
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Compare):
            for k, op in enumerate(node.ops):
                if type(op) in _CMP_SWAP:
                    yield node, "cmp", k
        elif isinstance(node, (ast.BinOp, ast.AugAssign)) and type(node.op) in _ARITH_SWAP:
            yield node, "arith", 0
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            yield node, "arith", 0
        elif isinstance(node, ast.Constant) and type(node.value) is int:
            yield node, "const", +1
            yield node, "const", -1
        elif isinstance(node, ast.Constant) and type(node.value) is bool:
            yield node, "not", 0
        elif isinstance(node, (ast.If, ast.While, ast.IfExp)):
            yield node, "not", 0
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
            yield node, "not", 0
        elif isinstance(node, ast.BoolOp):
            yield node, "boolop", 0
        elif (
            isinstance(node, ast.Return)
            and node.value is not None
            and not (isinstance(node.value, ast.Constant) and not node.value.value)
        ):  # (return False / 0 / "" → None is the same to every caller that tests it)
            yield node, "return", 0


def _apply(node: ast.AST, operator: str, variant: int) -> ast.AST | None:
    """Change ``node`` in place; a node to put in its place, if it is replaced."""
    if operator == "cmp":
        node.ops[variant] = _CMP_SWAP[type(node.ops[variant])]()
    elif operator == "arith" and isinstance(node, ast.UnaryOp):
        return node.operand
    elif operator == "arith":
        node.op = _ARITH_SWAP[type(node.op)]()
    elif operator == "const":
        node.value += variant
    elif operator == "not" and isinstance(node, ast.Constant):
        node.value = not node.value
    elif operator == "not" and isinstance(node, ast.UnaryOp):
        return node.operand
    elif operator == "not":
        node.test = ast.UnaryOp(ast.Not(), node.test)
    elif operator == "boolop":
        node.op = ast.Or() if isinstance(node.op, ast.And) else ast.And()
    elif operator == "return":
        node.value = ast.Constant(None)
    return None


def _shown(node: ast.AST) -> str:
    """A node as one line of source (a compound statement: its header)."""
    if isinstance(node, (ast.If, ast.While)):
        return ("if " if isinstance(node, ast.If) else "while ") + ast.unparse(node.test) + ":"
    return " ".join(ast.unparse(node).split())


def mutate(module: str, source: str, number: int) -> tuple[str, Mutant]:
    """Source of ``module`` with its ``number``-th mutation, and the mutant."""
    tree = ast.parse(source)
    for n, (node, operator, variant) in enumerate(list(_points(tree))):
        if n != number:
            continue
        before = _shown(node)
        replacement = _apply(node, operator, variant)
        if replacement is not None:
            _replace(tree, node, replacement)
        after = _shown(replacement if replacement is not None else node)
        ast.fix_missing_locations(tree)
        text = source.splitlines()[node.lineno - 1].strip()
        return ast.unparse(tree), Mutant(module, number, node.lineno, operator, before, after, text)
    raise IndexError(f"{module} has no mutation {number}")


def _replace(tree: ast.AST, old: ast.AST, new: ast.AST) -> None:
    for parent in ast.walk(tree):
        for field, value in ast.iter_fields(parent):
            if value is old:
                setattr(parent, field, new)
                return
            if isinstance(value, list):
                for i, item in enumerate(value):
                    if item is old:
                        value[i] = new
                        return


def mutants_of(module: str) -> list[Mutant]:
    """Every mutant of ``module`` (described, not applied)."""
    source = (ROOT / module).read_text()
    lines = source.splitlines()
    tree = ast.parse(source)
    out = []
    for n, (node, operator, variant) in enumerate(list(_points(tree))):
        before = _shown(node)
        node = copy.deepcopy(node)  # the tree stays as parsed for the points after this one
        replacement = _apply(node, operator, variant)
        after = _shown(replacement if replacement is not None else node)
        out.append(Mutant(module, n, node.lineno, operator, before, after, lines[node.lineno - 1].strip()))
    return out


def groups(selected: list[str] | None) -> dict[str, list[str]]:
    """The groups to run: named ones (a group or a single mapped module), else all."""
    if not selected:
        return dict(GROUPS)
    out = {}
    for name in selected:
        if name in GROUPS:
            out[name] = GROUPS[name]
        elif name in TESTS:
            out[name] = [name]
        else:
            raise SystemExit(
                f"mutants: error: {name!r} is neither a group ({', '.join(GROUPS)}) nor a mapped module"
            )
    return out


def load_equivalent() -> list[dict]:
    """The survivors classified as equivalent: module, line (its text), operator, before,
    after, reason (matched by text, not line number, so they outlive edits elsewhere)."""
    if not EQUIVALENT.exists():
        return []
    return tomllib.loads(EQUIVALENT.read_text()).get("mutant", [])


def is_equivalent(m: Mutant, equivalent: list[dict]) -> str | None:
    for entry in equivalent:
        if (entry["module"], entry["line"], entry["operator"], entry["before"], entry["after"]) == (
            m.module,
            m.text,
            m.operator,
            m.before,
            m.after,
        ):
            return entry["reason"]
    return None


class Workspace:
    """A private copy of the source tree where one mutant at a time is swapped in."""

    def __init__(self) -> None:
        self.root = Path(tempfile.mkdtemp(prefix="pencilbot-mutants-"))
        ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".hypothesis", ".pytest_cache")
        for name in COPIED:
            src = ROOT / name
            if src.is_dir():
                shutil.copytree(src, self.root / name, ignore=ignore)
            else:
                shutil.copy2(src, self.root / name)

    def run(self, tests: list[str], timeout: float, module: str | None = None, source: str | None = None):
        """Run ``tests`` with ``module`` replaced by ``source``: (outcome, seconds)."""
        target = self.root / module if module else None
        original = target.read_text() if target else None
        if target:
            target.write_text(source)
        env = dict(os.environ, PYTHONPATH=str(self.root), PYTHONDONTWRITEBYTECODE="1", PYTHONHASHSEED="0")
        start = time.monotonic()
        # Its own session: on a timeout the whole group goes (a pty server the tests started too).
        child = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "pytest",
                "-x",
                "-q",
                "-p",
                "no:cacheprovider",
                "--no-header",
                "-o",
                "addopts=",
                *tests,
            ],
            cwd=self.root,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        try:
            output, _ = child.communicate(timeout=timeout)
            outcome = {0: "survived", 1: "killed"}.get(child.returncode, f"error rc={child.returncode}")
            if child.returncode not in (0, 1):
                outcome += ": " + output.decode(errors="replace")[-300:]
        except subprocess.TimeoutExpired:
            os.killpg(child.pid, signal.SIGKILL)
            child.communicate()
            outcome = "timeout"
        finally:
            if target:
                target.write_text(original)
        return outcome, time.monotonic() - start

    def close(self) -> None:
        shutil.rmtree(self.root, ignore_errors=True)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--module",
        action="append",
        help="a group (driver, planning/ordering, …) or one mapped module (repeatable); default: all groups",
    )
    ap.add_argument("--sample", type=int, default=30, help="mutants per group, drawn at random (0: all)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=1, help="mutants run in parallel (one tree copy each)")
    ap.add_argument(
        "--timeout",
        type=float,
        default=None,
        help="seconds per mutant (default: 3 × the module's clean run + 20)",
    )
    ap.add_argument(
        "--number",
        type=int,
        action="append",
        help="only these mutants (their numbers in --list) of the one module given (repeatable)",
    )
    ap.add_argument("--list", action="store_true", help="list the mutants, run nothing")
    args = ap.parse_args(argv)

    chosen = groups(args.module)
    plan: dict[str, list[Mutant]] = {}
    for group, members in chosen.items():
        every = [m for module in members for m in mutants_of(module)]
        if args.number:
            every = [m for m in every if m.number in set(args.number)]
        rng = random.Random(f"{args.seed}:{group}")
        plan[group] = sorted(
            rng.sample(every, min(args.sample, len(every))) if args.sample else every,
            key=lambda m: (m.module, m.number),
        )
    if args.list:
        print(json.dumps({m: [vars(x) for x in ms] for m, ms in plan.items()}, indent=1, ensure_ascii=False))
        return

    equivalent = load_equivalent()
    workspaces = [Workspace() for _ in range(max(1, args.jobs))]
    free = list(workspaces)
    started = time.monotonic()
    report: dict[str, dict] = {}
    try:
        # The mapped tests must pass on the unmutated copy, and say how long they take (each
        # distinct set of tests once, on the workspaces side by side).
        needed = sorted({m.module for ms in plan.values() for m in ms})
        suites = sorted({tuple(TESTS[module]) for module in needed})

        def clean_run(k_suite):
            k, suite = k_suite
            return suite, workspaces[k % len(workspaces)].run(list(suite), timeout=900)

        by_suite = {}
        for start in range(0, len(suites), len(workspaces)):
            batch = list(enumerate(suites[start : start + len(workspaces)]))
            with ThreadPoolExecutor(len(batch)) as pool:
                by_suite.update(pool.map(clean_run, batch))
        clean = {}
        for module in needed:
            outcome, seconds = by_suite[tuple(TESTS[module])]
            if outcome != "survived":
                raise SystemExit(
                    f"mutants: error: {module}'s tests fail unmutated ({outcome}); fix them first"
                )
            clean[module] = seconds

        lock = threading.Lock()

        def one(mutant: Mutant):
            with lock:
                ws = free.pop()
            try:
                source, _ = mutate(mutant.module, (ROOT / mutant.module).read_text(), mutant.number)
                timeout = args.timeout or 3 * clean[mutant.module] + 20
                outcome, seconds = ws.run(TESTS[mutant.module], timeout, mutant.module, source)
                print(
                    f"{outcome.split(':')[0]:9s} {seconds:5.1f} s  {mutant.where()}  {mutant.operator}: "
                    f"{mutant.before} -> {mutant.after}",
                    file=sys.stderr,
                    flush=True,
                )
                return mutant, outcome
            finally:
                with lock:
                    free.append(ws)

        jobs = [m for ms in plan.values() for m in ms]
        with ThreadPoolExecutor(len(workspaces)) as pool:
            results = list(pool.map(one, jobs))
    finally:
        for ws in workspaces:
            ws.close()

    totals = {"killed": 0, "total": 0, "equivalent": 0}
    for group in chosen:
        rows = [(m, o) for m, o in results if m in set(plan[group])]
        survivors, equal, errors = [], [], []
        for m, outcome in rows:
            if outcome.startswith("error"):
                errors.append(
                    {
                        "where": m.where(),
                        "operator": m.operator,
                        "before": m.before,
                        "after": m.after,
                        "outcome": outcome,
                    }
                )
            elif outcome == "survived":
                reason = is_equivalent(m, equivalent)
                entry = {
                    "where": m.where(),
                    "operator": m.operator,
                    "line": m.text,
                    "before": m.before,
                    "after": m.after,
                }
                (equal if reason else survivors).append({**entry, **({"reason": reason} if reason else {})})
        killed = sum(o in ("killed", "timeout") for _, o in rows)
        counted = len(rows) - len(errors)
        report[group] = {
            "killed": killed,
            "total": counted,
            "equivalent": len(equal),
            "score": round(killed / max(counted - len(equal), 1), 3),
            "space": sum(len(mutants_of(module)) for module in chosen[group]),
            "survivors": survivors,
            "equivalent_survivors": equal,
            **({"errors": errors} if errors else {}),
        }
        totals["killed"] += killed
        totals["total"] += counted
        totals["equivalent"] += len(equal)
    totals["score"] = round(totals["killed"] / max(totals["total"] - totals["equivalent"], 1), 3)
    out = {
        "command": "python bench/mutants.py " + " ".join(argv if argv is not None else sys.argv[1:]),
        "seed": args.seed,
        "sample": args.sample,
        "jobs": args.jobs,
        "wall_s": round(time.monotonic() - started, 1),
        "total": totals,
        "clean_run_s": {m: round(t, 1) for m, t in clean.items()},
        "groups": report,
    }
    print(json.dumps(out, indent=1, ensure_ascii=False))


if __name__ == "__main__":
    main()
