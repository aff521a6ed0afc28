"""scripts/stack.sh's own parts, on this machine's processes (no stack needed)."""

from __future__ import annotations

import os
import subprocess

from tests.stack import ROOT

SCRIPT = ROOT / "scripts" / "stack.sh"


def test_a_live_stack_process_with_a_large_environment_is_always_recognised(tmp_path):
    """stack.sh stops a process only once `ours` says it is gone: a live one must never look gone
    (e.g. when reading its environment lost a race), or a restart starts the new process beside the
    old one, which may still hold the robot link's lease."""
    stack_dir = str(tmp_path)
    env = {"PATH": os.environ["PATH"], "CYBORG_STACK": stack_dir, "PADDING": "x" * 100_000}
    process = subprocess.Popen(["sleep", "60"], env=env)
    ours = "".join(_function(SCRIPT.read_text(), "ours"))
    try:
        check = (f"set -euo pipefail\nSTACK_DIR={stack_dir}\n{ours}\n"
                 f"for _ in $(seq 300); do ours {process.pid} || {{ echo looked gone; exit 1; }}; done")
        out = subprocess.run(["bash", "-c", check], capture_output=True, text=True, timeout=60)
        assert out.returncode == 0, out.stdout + out.stderr
    finally:
        process.kill()
        process.wait()
    gone = subprocess.run(["bash", "-c", f"STACK_DIR={stack_dir}\n{ours}\nours {process.pid}"], timeout=10)
    assert gone.returncode == 1


def _function(script: str, name: str) -> list[str]:
    lines = script.splitlines(keepends=True)
    start = lines.index(f"{name}() {{\n")
    return lines[start:lines.index("}\n", start) + 1]
