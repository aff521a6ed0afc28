"""`make run` with other ports: the server must talk to the simulator that run started."""

from __future__ import annotations

import functools
import http.cookiejar
import json
import os
import re
import signal
import socket
import subprocess
import tempfile
import time
import urllib.parse
import urllib.request
from pathlib import Path

import pytest

from tests.stack import ROOT, free_port, wait_for_port

# make run brings its own SQLite and in-memory layer: the services pass would repeat the same thing.
pytestmark = pytest.mark.skipif(bool(os.environ.get("DATABASE_URL")), reason="runs in the embedded pass only")


def _health(port: int) -> dict:
    with urllib.request.urlopen(f"http://127.0.0.1:{port}/healthz", timeout=2) as res:
        return json.loads(res.read())


def _logged_in(port: int, username: str, password: str) -> urllib.request.OpenerDirector:
    jar = http.cookiejar.CookieJar()
    opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor(jar))
    url = f"http://127.0.0.1:{port}/accounts/login/"
    opener.open(url, timeout=10).read()
    token = next(c.value for c in jar if c.name == "csrftoken")
    body = urllib.parse.urlencode({"username": username, "password": password, "csrfmiddlewaretoken": token})
    with opener.open(urllib.request.Request(url, data=body.encode(), headers={"Referer": url}), timeout=10) as res:
        assert "/accounts/login/" not in res.url, "the printed admin password did not log in"
    return opener


def _listening(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def test_make_run_with_other_ports_connects_to_the_simulator_it_started():
    ports = {"PORT": free_port(), "SIM_PORT": free_port(), "VIDEO_PORT": free_port()}
    with tempfile.TemporaryDirectory(prefix="cyborg-make-run-") as tmp:
        env = {k: v for k, v in os.environ.items()
               if k not in ("ROSBRIDGE_URL", "VIDEO_URL", "DATABASE_URL", "REDIS_URL", "MAKEFLAGS", "MFLAGS")}
        env.update({name: str(port) for name, port in ports.items()}, VAR_DIR=tmp)
        log = Path(tmp) / "make.log"
        with log.open("w") as out:
            # As from a terminal: Ctrl-C must work even when this suite runs where SIGINT is ignored (a
            # script's background job), which every process below would inherit.
            make = subprocess.Popen(["make", "--no-print-directory", "run"], cwd=ROOT, env=env, stdout=out,
                                    stderr=subprocess.STDOUT, start_new_session=True,
                                    preexec_fn=functools.partial(signal.signal, signal.SIGINT, signal.SIG_DFL))
        try:
            wait_for_port(ports["PORT"], timeout=120, proc=make)
            deadline = time.monotonic() + 30
            health: dict = {}
            while time.monotonic() < deadline and not health.get("connected"):
                try:
                    health = _health(ports["PORT"])
                except OSError:
                    pass
                time.sleep(0.2)
            assert health.get("connected"), log.read_text()[-3000:]
            assert f"talks to ws://127.0.0.1:{ports['SIM_PORT']}" in log.read_text()
            # The addresses in /healthz and the camera through the server, as the first admin sees them.
            password = re.search(r"Log in as\s+admin / (\S+)", log.read_text())
            assert password, log.read_text()[-3000:]
            opener = _logged_in(ports["PORT"], "admin", password[1])
            with opener.open(f"http://127.0.0.1:{ports['PORT']}/healthz", timeout=10) as res:
                health = json.loads(res.read())
            assert health["robot_url"] == f"ws://127.0.0.1:{ports['SIM_PORT']}"
            assert health["video_url"] == f"http://127.0.0.1:{ports['VIDEO_PORT']}"
            with opener.open(f"http://127.0.0.1:{ports['PORT']}/video/snapshot", timeout=10) as res:
                assert res.headers["Content-Type"] == "image/jpeg"
                assert res.read(3) == b"\xff\xd8\xff"
        finally:
            os.killpg(make.pid, signal.SIGINT)  # what Ctrl-C in the terminal does
            try:
                make.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(make.pid, signal.SIGKILL)
                make.wait(5)
                pytest.fail(f"make run did not stop on Ctrl-C:\n{log.read_text()[-3000:]}")
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and any(_listening(p) for p in ports.values()):
            time.sleep(0.1)
        assert not [name for name, port in ports.items() if _listening(port)], "a process outlived make run"
