"""The uplink agent as a real process on the oldest Python this machine has, and its credentials."""

from __future__ import annotations

import glob
import os
import signal
import subprocess
import tempfile
import time
from pathlib import Path

from tests.stack import ROOT

# The robot runs Ubuntu 16.04's Python 3.5; the oldest pyenv here is 3.6 (3.5 cannot be built offline).
AGENT_MINIMUM = "3.6"


def agent_python() -> str:
    root = Path(os.environ.get("PYENV_ROOT", Path.home() / ".pyenv"))
    found = sorted(glob.glob(str(root / "versions" / f"{AGENT_MINIMUM}.*" / "bin" / "python")))
    if not found:
        raise RuntimeError(f"no Python {AGENT_MINIMUM} under {root}/versions: the agent is tested on its minimum")
    return found[-1]


def make_credential(robot: str = "cyborg") -> tuple[object, str]:
    from robot.uplink.credentials import credential_create

    return credential_create(robot=robot, label="test")


class Agent:
    """``python -m uplink_agent`` with its settings in the environment; ``prefix`` runs it elsewhere
    (``ip netns exec NS``)."""

    def __init__(self, *, server_url: str, credential: str, rosbridge_url: str, video_url: str,
                 prefix: tuple[str, ...] = (), **extra: str) -> None:
        self.log_path = Path(tempfile.mkstemp(prefix="uplink-agent-", suffix=".log")[1])
        self.prefix = prefix
        self.env = {
            "PATH": os.environ.get("PATH", ""), "PYTHONPATH": str(ROOT), "PYTHONUNBUFFERED": "1",
            "UPLINK_SERVER_URL": server_url, "UPLINK_CREDENTIAL": credential,
            "UPLINK_ROSBRIDGE_URL": rosbridge_url, "UPLINK_VIDEO_URL": video_url,
            "UPLINK_BACKOFF_MAX_S": "1", "UPLINK_LOG_LEVEL": "INFO", **extra,
        }
        self.proc: subprocess.Popen | None = None

    def start(self) -> Agent:
        log = open(self.log_path, "a")
        self.proc = subprocess.Popen([*self.prefix, agent_python(), "-m", "uplink_agent"], cwd=ROOT, env=self.env,
                                     stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        return self

    def stop(self, sig: int = signal.SIGTERM) -> None:
        if self.proc is not None and self.proc.poll() is None:
            os.killpg(self.proc.pid, sig)
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(5)

    def log(self) -> str:
        return self.log_path.read_text()

    def wait_log(self, text: str, timeout: float = 10.0, after: int = 0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if text in self.log()[after:]:
                return
            time.sleep(0.05)
        raise AssertionError(f"the agent never logged {text!r}:\n{self.log()[-3000:]}")

    def __enter__(self) -> Agent:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
        self.log_path.unlink(missing_ok=True)
