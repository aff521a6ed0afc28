"""`make run`'s last step (scripts/run.sh): the simulator and the server until a Ctrl-C, which stops
both cleanly: no "Segmentation fault" from the shell, nothing left running, exit status 0, and
neither the link's first connect nor the stop leaves a traceback in the log."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.stack import ROOT, free_port, wait_for_port

BIN = str(Path(sys.executable).parent)
# Each starts a simulator and a server: on a loaded machine that alone can take minutes.
pytestmark = pytest.mark.timeout(420)


def _listening(port: int) -> bool:
    import socket

    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def _as_from_a_terminal() -> None:
    """Ctrl-C at its default, as in a terminal: an xdist worker ignores SIGINT, its children would too,
    and a shell cannot trap a signal ignored on entry."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@contextlib.contextmanager
def _run_sh() -> Iterator[tuple[subprocess.Popen, Path, tuple[int, int, int]]]:
    """scripts/run.sh on free ports with a fresh VAR_DIR, in a session of its own (a signal goes to the
    whole group, as a terminal's Ctrl-C does); killed if the test left it running."""
    var = tempfile.mkdtemp(prefix="cyborg-run-")
    env = {k: v for k, v in os.environ.items() if k not in ("REDIS_URL", "DATABASE_URL")} | {"VAR_DIR": var}
    subprocess.run([sys.executable, "manage.py", "migrate", "--noinput"], cwd=ROOT, env=env, check=True,
                   capture_output=True)
    web, sim, video = free_port(), free_port(), free_port()
    out = Path(var) / "run.log"
    with out.open("w") as log:
        run = subprocess.Popen(["bash", "scripts/run.sh", BIN, str(web), str(sim), str(video),
                                f"ws://127.0.0.1:{sim}", f"http://127.0.0.1:{video}"],
                               cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
                               preexec_fn=_as_from_a_terminal)
        try:
            yield run, out, (web, sim, video)
        finally:
            if run.poll() is None:
                os.killpg(run.pid, signal.SIGKILL)


def test_a_ctrl_c_stops_the_simulator_and_the_server_cleanly():
    with _run_sh() as (run, out, (web, sim, video)):
        wait_for_port(web, 180, run)  # a loaded machine is slow to start both
        deadline = time.monotonic() + 120
        while "robot link connected" not in out.read_text() and time.monotonic() < deadline:
            time.sleep(0.2)
        assert "robot link connected" in out.read_text(), out.read_text()[-3000:]
        time.sleep(3)  # the reconnect timer the link's first connect may leave behind would fire now
        os.killpg(run.pid, signal.SIGINT)
        assert run.wait(30) == 0, out.read_text()[-3000:]
    text = out.read_text()
    assert "Segmentation fault" not in text
    assert not _listening(web) and not _listening(sim) and not _listening(video)
    # No CRITICAL Twisted traceback from the link's reconnect timer, no stack of a task the stop ended.
    assert "can't connect in this state" not in text and "CRITICAL" not in text, text[-4000:]
    assert "CancelledError" not in text, text[-4000:]


def _child_running(parent: int, word: str) -> int:
    """The pid of ``parent``'s child whose command line has ``word``."""
    for task in Path(f"/proc/{parent}/task").iterdir():
        for pid in (task / "children").read_text().split():
            if word in Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace"):
                return int(pid)
    raise AssertionError(f"no child of {parent} runs {word}")


def _robot_connected(web: int) -> bool | None:
    import urllib.error
    import urllib.request

    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{web}/healthz", timeout=2) as res:
            body = res.read()
    except urllib.error.HTTPError as err:  # 503 while the robot is offline
        body = err.read()
    except OSError:
        return None
    return b'"connected": true' in body


def test_the_server_keeps_running_when_the_simulator_dies():
    with _run_sh() as (run, out, (web, sim, video)):
        wait_for_port(web, 180, run)
        deadline = time.monotonic() + 120
        while not _robot_connected(web) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert _robot_connected(web), out.read_text()[-3000:]
        os.kill(_child_running(run.pid, "simulator"), signal.SIGKILL)  # the simulator crashes
        deadline = time.monotonic() + 60
        while _robot_connected(web) is not False and time.monotonic() < deadline:
            time.sleep(0.2)
        assert _robot_connected(web) is False, out.read_text()[-3000:]  # up, and says the robot is offline
        assert run.poll() is None and "the server keeps running" in out.read_text()
        os.killpg(run.pid, signal.SIGINT)  # Ctrl-C still stops everything
        assert run.wait(30) == 0, out.read_text()[-3000:]
    assert not _listening(web) and not _listening(sim) and not _listening(video)
