"""The embedded default's private Valkey server: one per process, started on first use (from any
thread), gone when its process exits or is killed outright."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from django.conf import settings

from tests.helpers import wait_until

ROOT = Path(__file__).resolve().parents[2]
CHILD = """
import sys, threading, django
django.setup()
from robot.live import private_server, redis_clients
# Started from a thread that ends at once, as a thread pool's would: the server must outlive it.
starter = threading.Thread(target=lambda: redis_clients.client().set("k", "v"))
starter.start(); starter.join()
print(private_server._process.pid, redis_clients.client().get("k").decode(), flush=True)
if sys.argv[1] == "wait":
    sys.stdin.read()
"""

pytestmark = pytest.mark.skipif(not settings.EMBEDDED, reason="the embedded default's own server")


def _child(mode: str) -> tuple[subprocess.Popen, int]:
    env = {k: v for k, v in os.environ.items() if k not in ("REDIS_URL", "DATABASE_URL")}
    child = subprocess.Popen([sys.executable, "-c", CHILD, mode], cwd=ROOT, env=env, text=True,
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    assert child.stdout is not None
    line = child.stdout.readline().split()
    assert line[1:] == ["v"], line
    return child, int(line[0])


def _gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    # A zombie until its parent (init, once the child died) reaps it.
    return Path(f"/proc/{pid}/stat").read_text().split()[2] == "Z"


def _dirs(pid: int) -> list[Path]:
    return list(Path(settings.REDIS_URL.removeprefix("unix://")).parent.parent.glob(f"cyborg-valkey-{pid}-*"))


def test_a_process_that_exits_stops_its_server_and_removes_its_directory():
    child, server = _child("exit")
    assert child.wait(60) == 0
    wait_until(lambda: _gone(server), timeout=30, what="the private server stopped")
    assert _dirs(child.pid) == []


@pytest.mark.skipif(sys.platform != "linux", reason="the parent-death signal is Linux's")
def test_a_process_killed_outright_takes_its_server_with_it():
    child, server = _child("wait")
    assert not _gone(server)
    assert _dirs(child.pid), "each process has a server (and a directory) of its own"
    os.kill(child.pid, signal.SIGKILL)
    child.wait(10)
    wait_until(lambda: _gone(server), timeout=30, what="the private server gone with its process")
