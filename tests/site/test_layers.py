"""Imports point down: the robot package never reaches up into the pages, and the simulator's
servers see the simulator only through its protocols."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _imports(path: Path) -> set[str]:
    """Absolute module names ``path`` imports (relative imports resolved against its package)."""
    package = path.relative_to(ROOT).with_suffix("").parts[:-1]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = list(package[: len(package) - node.level + 1]) if node.level else []
            module = ".".join([*base, *([node.module] if node.module else [])])
            found.add(module)
            found.update(f"{module}.{alias.name}" for alias in node.names)
    return found


def test_nothing_under_robot_imports_the_pages_or_history():
    offenders = {
        str(path.relative_to(ROOT)): sorted(m for m in _imports(path) if m.split(".")[0] in ("dashboard", "history"))
        for path in (ROOT / "robot").rglob("*.py")
    }
    assert {p: m for p, m in offenders.items() if m} == {}


def test_the_simulators_servers_do_not_import_the_robot_they_serve():
    for name in ("server.py", "camera.py", "host.py", "bus.py"):
        imported = _imports(ROOT / "robot" / "sim" / name)
        assert not {m for m in imported if m.startswith("robot.sim.robot") or m.startswith("robot.sim.nodes")}, name


def test_simulated_nodes_reach_the_simulator_only_through_the_bus_and_the_shared_models():
    for path in (ROOT / "robot" / "sim" / "nodes").glob("*.py"):
        imported = _imports(path)
        assert not {m for m in imported if m.split(".")[:3] in (["robot", "sim", "robot"], ["robot", "sim", "server"],
                                                                 ["robot", "sim", "camera"])}, path.name
        assert not {m for m in imported if m.startswith(("django", "channels", "dashboard"))}, path.name
