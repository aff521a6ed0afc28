"""The agent runs on the robot's Python 3.5: its source keeps to what 3.5 has."""

from __future__ import annotations

import ast
import subprocess
from pathlib import Path

import pytest

from tests.stack import ROOT
from tests.uplink.support import agent_python

SOURCES = sorted((ROOT / "uplink_agent").glob("*.py"))
# Standard library names newer than 3.5 that an agent must not use.
NEWER_ASYNCIO = {"run", "create_task", "get_running_loop", "timeout", "TaskGroup", "to_thread"}
NEWER = {"start_tls", "removeprefix", "removesuffix"}


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: p.name)
def test_it_keeps_to_python_3_5(path: Path) -> None:
    tree = ast.parse(path.read_text(), feature_version=(3, 5))  # refuses variable annotations and more
    for node in ast.walk(tree):
        assert not isinstance(node, ast.JoinedStr), f"{path.name}:{node.lineno}: an f-string (3.6+)"
        if isinstance(node, ast.AsyncFunctionDef):
            assert not any(isinstance(n, (ast.Yield, ast.YieldFrom)) for n in ast.walk(node)), \
                f"{path.name}: an asynchronous generator (3.6+)"
        if isinstance(node, ast.Attribute):
            in_asyncio = isinstance(node.value, ast.Name) and node.value.id == "asyncio"
            assert node.attr not in NEWER and not (in_asyncio and node.attr in NEWER_ASYNCIO), \
                f"{path.name}:{node.lineno}: .{node.attr} is newer than Python 3.5"
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            module = getattr(node, "module", None) or node.names[0].name
            assert module.split(".")[0] in {"asyncio", "base64", "hashlib", "ipaddress", "json", "logging", "os",
                                            "random", "signal", "socket", "ssl", "struct", "sys", "time",
                                            "urllib", ""} or getattr(node, "level", 0), f"{path.name}: imports {module}"


def test_it_starts_on_its_minimum_python_and_refuses_a_plain_address() -> None:
    run = subprocess.run([agent_python(), "-m", "uplink_agent"], cwd=ROOT, capture_output=True, text=True, timeout=20,
                         env={"UPLINK_SERVER_URL": "ws://cyborg.example.org/uplink/", "UPLINK_CREDENTIAL": "x"})
    assert run.returncode != 0 and "plain ws:// only to loopback" in run.stderr
