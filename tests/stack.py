"""The whole product as real processes: simulator + Daphne (+ optional Celery worker), or
scaled on a given Redis: simulator + Daphne + a ``robotlink`` process.

Used by browser tests and benchmarks. Each stack gets its own SQLite file (or the
given DATABASE_URL), free ports, and users per role.
"""

from __future__ import annotations

import atexit
import contextlib
import http.cookiejar
import itertools
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse
import urllib.request
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PYTHON = sys.executable
PASSWORD = "correct-horse-battery"
USERS = {"ada": "admin", "otto": "operator", "olga": "operator", "vera": "viewer"}
_migrated: dict[bool, Path] = {}  # with USERS or without: a migrated SQLite file for Stack.prepare_database


def _port_range() -> Iterator[int]:
    """Ports this test process hands out: a block of its own per xdist worker, below the kernel's
    ephemeral range (32768+), so two workers never pick the same free port at the same moment."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw")
    base = 20000 + (int(worker) % 25) * 500
    return itertools.cycle(range(base, base + 500))


_ports = _port_range()


def free_port() -> int:
    for port in _ports:
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
            return port
    raise AssertionError("unreachable")


def wait_for_port(port: int, timeout: float = 180.0, proc: subprocess.Popen | None = None) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc is not None and proc.poll() is not None:
            raise RuntimeError(f"process exited early with {proc.returncode}")
        try:
            with socket.create_connection(("127.0.0.1", port), 0.2):
                return
        except OSError:
            time.sleep(0.05)
    raise RuntimeError(f"nothing listening on {port} after {timeout} s")


def _kill(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)


class Stack:
    def __init__(self, *, sim: bool = True, sim_args: tuple[str, ...] = (), env: dict[str, str] | None = None,
                 users: bool = True, redis_url: str | None = None, webs: int = 1) -> None:
        self.tmp = Path(tempfile.mkdtemp(prefix="cyborg-stack-"))
        # Scaled (redis_url), several web processes may share the one link.
        self.web_ports = [free_port() for _ in range(webs)]
        self.web_port = self.web_ports[0]
        self.sim_port = free_port()
        self.video_port = free_port()
        self.with_sim = sim
        self.sim_args = sim_args
        self.procs: list[subprocess.Popen] = []
        self.users = users
        self.env = {
            **{k: v for k, v in os.environ.items() if k not in ("REDIS_URL", "DATABASE_URL")},
            "VAR_DIR": str(self.tmp),
            "DATABASE_URL": f"sqlite:///{self.tmp / 'db.sqlite3'}",
            "ROSBRIDGE_URL": f"ws://127.0.0.1:{self.sim_port}",
            "VIDEO_URL": f"http://127.0.0.1:{self.video_port}",
            "ROBOT_LINK_MAX_BACKOFF_S": "1",
            "DJANGO_SETTINGS_MODULE": "cyborg_site.settings",
            "PYTHONUNBUFFERED": "1",
            **({"REDIS_URL": redis_url, "ROBOT_LINK_DIRECT_ADDRESSES": f"127.0.0.1:{free_port()},{free_port()}"}
               if redis_url else {}),
            **(env or {}),
        }
        self.scaled = bool(redis_url)

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.web_port}"

    def manage(self, *args: str) -> str:
        out = subprocess.run([PYTHON, "manage.py", *args], cwd=ROOT, env=self.env, check=True,
                             capture_output=True, text=True, timeout=120)
        return out.stdout

    def _spawn(self, args: list[str], name: str) -> subprocess.Popen:
        log = open(self.tmp / f"{name}.log", "w")
        proc = subprocess.Popen(args, cwd=ROOT, env=self.env, stdout=log, stderr=subprocess.STDOUT,
                                start_new_session=True)
        self.procs.append(proc)
        return proc

    def start_sim(self) -> subprocess.Popen:
        proc = self._spawn([PYTHON, "-m", "simulator", "--port", str(self.sim_port),
                            "--video-port", str(self.video_port), *self.sim_args], "sim")
        wait_for_port(self.sim_port, proc=proc)
        self.sim_proc = proc
        return proc

    def stop_sim(self) -> None:
        self._terminate(self.sim_proc)

    def start(self) -> Stack:
        self.prepare_database()
        if self.with_sim:
            self.start_sim()
        if self.scaled:
            self.start_link()
        self.start_web()
        return self

    def prepare_database(self) -> None:
        """Migrated, with USERS unless told otherwise: a copy of the first such SQLite file of this
        test process (migrating costs seconds of CPU per stack), made by migrating the first time."""
        db = self.tmp / "db.sqlite3"
        own_sqlite = self.env["DATABASE_URL"] == f"sqlite:///{db}"
        template = _migrated.get(self.users) if own_sqlite else None
        if template is not None:
            for path in template.parent.glob("db.sqlite3*"):  # with its WAL, if the last writer left one
                shutil.copy(path, self.tmp / path.name)
            return
        self.manage("migrate", "--noinput")
        if self.users:
            self.add_users()
        if own_sqlite:
            keep = Path(tempfile.mkdtemp(prefix="cyborg-stack-db-"))
            atexit.register(shutil.rmtree, keep, True)
            for path in self.tmp.glob("db.sqlite3*"):
                shutil.copy(path, keep / path.name)
            _migrated[self.users] = keep / "db.sqlite3"

    def add_users(self) -> None:
        """``manage.py adduser`` for each of USERS, in one process: Django's start-up is most of a command's cost."""
        calls = "".join(f"call_command('adduser', {name!r}, role={role!r}, password={PASSWORD!r})\n"
                        for name, role in USERS.items())
        self.manage("shell", "-c", "from django.core.management import call_command\n" + calls)

    def start_link(self) -> subprocess.Popen:
        self.link_proc = self._spawn([PYTHON, "manage.py", "robotlink"], "link")
        return self.link_proc

    def start_web(self) -> subprocess.Popen:
        self.webs = [
            self._spawn([PYTHON, "-m", "daphne", "-b", "127.0.0.1", "-p", str(port), "server.asgi:application"],
                        "web" if i == 0 else f"web{i}")
            for i, port in enumerate(self.web_ports)
        ]
        for port, proc in zip(self.web_ports, self.webs, strict=True):
            wait_for_port(port, proc=proc)
        self.web = self.webs[0]
        return self.web

    def login_cookie(self, username: str) -> str:
        """Log in through the form like a browser; return the Cookie header."""
        jar = http.cookiejar.CookieJar()
        opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor(jar))
        page = opener.open(f"{self.url}/accounts/login/", timeout=10).read().decode()
        token = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page).group(1)  # type: ignore[union-attr]
        form = urllib.parse.urlencode({"username": username, "password": PASSWORD, "csrfmiddlewaretoken": token})
        opener.open(urllib.request.Request(f"{self.url}/accounts/login/", data=form.encode(),
                                           headers={"Referer": f"{self.url}/accounts/login/"}), timeout=10).read()
        cookies = {c.name: c.value for c in jar}
        if "sessionid" not in cookies:
            raise RuntimeError(f"login as {username} failed")
        return "; ".join(f"{k}={v}" for k, v in cookies.items())

    def wait_robot_online(self, timeout: float = 20.0) -> None:
        """Poll the server until its link reports the robot connected."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                with urllib.request.urlopen(f"{self.url}/healthz", timeout=1) as res:
                    if b'"connected": true' in res.read():
                        return
            except OSError:
                pass
            time.sleep(0.1)
        raise RuntimeError("the server's link never connected to the simulator:\n" + self.log("web")[-3000:])

    def log(self, name: str) -> str:
        path = self.tmp / f"{name}.log"
        return path.read_text() if path.exists() else ""

    def _terminate(self, proc: subprocess.Popen) -> None:
        if proc.poll() is None:
            try:
                os.killpg(proc.pid, signal.SIGTERM)
                proc.wait(5)
            except (subprocess.TimeoutExpired, ProcessLookupError):
                _kill(proc)
                proc.wait(5)

    def stop(self) -> None:
        try:
            for proc in reversed(self.procs):
                self._terminate(proc)
        finally:  # one slow to end, or the test's time-out striking meanwhile, must leave none running
            for proc in self.procs:
                _kill(proc)
            shutil.rmtree(self.tmp, ignore_errors=True)

    def __enter__(self) -> Stack:
        try:
            return self.start()
        except Exception:
            self.stop()
            raise

    def __exit__(self, *exc) -> None:
        self.stop()
