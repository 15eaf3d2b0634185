"""The house rules, read from the code: every package imports only downward, nothing runs in
a circle, modules and functions stay a readable size, imports sit at the top of their module.

The floors, lowest first: ``msgs_py`` (the message layer, no ROS outside ``msgs_py.ros``),
``nodes.common`` (plumbing), ``nodes.robot`` (the robot's model); the node packages (``sim``,
``detector``, ``planner``, ``executor``, ``arm``, ``gripper``, ``goal``), which never import
each other; ``nodes.calibration`` (uses the detector and the executor) and ``nodes.cell`` (a
cell launched and driven on its action); ``nodes.bench`` (benchmarks, scene
sets, in-process players: may use every node package); ``nodes.tools`` (the command-line tools).
"""

from __future__ import annotations

import ast
from pathlib import Path

from tests.helpers import REPO

FLOORS = {
    "msgs_py": 0,
    "nodes.common": 1,
    "nodes.robot": 2,
    "nodes.sim": 3, "nodes.detector": 3, "nodes.planner": 3, "nodes.executor": 3,
    "nodes.arm": 3, "nodes.gripper": 3, "nodes.goal": 3,
    "nodes.calibration": 4, "nodes.cell": 4,
    "nodes.bench": 5,
    "nodes.tools": 6,
}
MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 60
#: Imports inside a function, each with its measured reason.
LOCAL_IMPORTS_ALLOWED = {
    # matplotlib costs about 0.9 s of start-up here: paid only when a picture is drawn
    "nodes.cell.timeline.write_timeline",
    "nodes.planner.cli.main",
    "nodes.tools.run.draw_plan",
}


def modules() -> list[tuple[str, Path]]:
    files = sorted([*REPO.glob("nodes/**/*.py"), *REPO.glob("msgs_py/**/*.py")])
    return [(".".join(f.relative_to(REPO).with_suffix("").parts), f) for f in files]


def package(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] == "msgs_py":
        return "msgs_py"
    if parts[0] == "nodes" and len(parts) > 1:
        return f"nodes.{parts[1]}"
    return None


def imported(tree: ast.AST) -> list[tuple[str, int]]:
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.module, node.lineno))
        elif isinstance(node, ast.Import):
            found += [(alias.name, node.lineno) for alias in node.names]
    return found


def test_every_package_imports_only_downward():
    wrong = []
    for module, path in modules():
        here = package(module)
        for name, line in imported(ast.parse(path.read_text())):
            there = package(name)
            if there is None or there == here:
                continue
            if FLOORS[there] >= FLOORS[here]:
                wrong.append(f"{module}:{line} imports {name}")
    assert not wrong, "\n".join(wrong)


def test_no_import_runs_in_a_circle():
    graph: dict[str, set[str]] = {}
    known = {m for m, _ in modules()}
    for module, path in modules():
        graph[module] = {n for n, _ in imported(ast.parse(path.read_text())) if n in known}
    seen: dict[str, int] = {}

    def visit(node: str, stack: list[str]) -> list[str] | None:
        seen[node] = 1
        for nxt in graph[node]:
            if seen.get(nxt) == 1:
                return [*stack, node, nxt]
            if nxt not in seen and (cycle := visit(nxt, [*stack, node])):
                return cycle
        seen[node] = 2
        return None

    for module in graph:
        if module not in seen:
            cycle = visit(module, [])
            assert cycle is None, " -> ".join(cycle)


def test_modules_and_functions_stay_readable():
    long_modules = [f"{m}: {n} lines" for m, p in modules()
                    if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES]
    long_functions = []
    for module, path in modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                length = node.end_lineno - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    long_functions.append(f"{module}.{node.name}: {length} lines")
    assert not long_modules and not long_functions, "\n".join(long_modules + long_functions)


def test_imports_sit_at_the_top_of_their_module():
    local = []
    for module, path in modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                for inner in ast.walk(node):
                    if isinstance(inner, ast.Import | ast.ImportFrom):
                        key = f"{module}.{node.name}"
                        if key not in LOCAL_IMPORTS_ALLOWED:
                            local.append(f"{key}:{inner.lineno}")
    assert not local, "\n".join(local)
