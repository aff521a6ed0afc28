"""Real processes for the scaled wiring: a private redis-server that can be stopped and
started again for real, and helpers to drive a stack over HTTP and websockets."""

from __future__ import annotations

import contextlib
import json
import re
import subprocess
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Iterator
from http.cookiejar import CookieJar

from tests.stack import PASSWORD, Stack, free_port, wait_for_port


class PrivateRedis:
    """``redis-server`` on a port of its own, never the machine's (6379)."""

    def __init__(self) -> None:
        self.port = free_port()
        self.proc: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        return f"redis://127.0.0.1:{self.port}/0"

    def start(self) -> PrivateRedis:
        self.proc = subprocess.Popen(
            ["redis-server", "--port", str(self.port), "--bind", "127.0.0.1", "--save", "", "--appendonly", "no"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_for_port(self.port, proc=self.proc)
        return self

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(10)


class Client:
    """An operator logged in through the login form, like a browser."""

    def __init__(self, stack: Stack, username: str) -> None:
        self.stack = stack
        jar = CookieJar()
        self.opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor(jar))
        page = self.opener.open(f"{stack.url}/accounts/login/", timeout=10).read().decode()
        token = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page).group(1)
        form = urllib.parse.urlencode({"username": username, "password": PASSWORD, "csrfmiddlewaretoken": token})
        self.opener.open(urllib.request.Request(f"{stack.url}/accounts/login/", data=form.encode()), timeout=10).read()
        cookies = {c.name: c.value for c in jar}
        assert "sessionid" in cookies, "login failed"
        self.cookie = "; ".join(f"{k}={v}" for k, v in cookies.items())
        self.csrf = cookies["csrftoken"]

    def request(self, method: str, path: str, body: dict | None = None, timeout: float = 10) -> tuple[int, dict]:
        data = json.dumps(body).encode() if body is not None else None
        request = urllib.request.Request(f"{self.stack.url}{path}", data=data, method=method, headers={
            "Cookie": self.cookie, "X-CSRFToken": self.csrf, "Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=timeout) as res:
                return res.status, json.loads(res.read() or b"{}")
        except urllib.error.HTTPError as err:
            raw = err.read()
            try:
                return err.code, json.loads(raw or b"{}")
            except ValueError:
                return err.code, {"detail": raw.decode(errors="replace")[:200]}

    def post(self, path: str, body: dict | None = None, timeout: float = 10) -> tuple[int, dict]:
        return self.request("POST", path, body or {}, timeout)

    def get(self, path: str, timeout: float = 10) -> tuple[int, dict]:
        return self.request("GET", path, None, timeout)


def received(stack: Stack, topic: str = "/cmd_vel") -> list[dict]:
    """Every message the simulator received on ``topic``, with its receive time."""
    url = f"http://127.0.0.1:{stack.video_port}/sim/received?topic={urllib.parse.quote(topic)}"
    with urllib.request.urlopen(f"{url}&last=0", timeout=5) as res:
        count = json.loads(res.read())["count"]
    with urllib.request.urlopen(f"{url}&last={max(count, 1)}", timeout=5) as res:
        return json.loads(res.read())["messages"]


class Script:
    """A script with an API token."""

    def __init__(self, stack: Stack, username: str) -> None:
        self.url = stack.url
        self.token = self._call("POST", "/api/auth/token/", {"username": username, "password": PASSWORD},
                                auth=False)[1]["token"]

    def post(self, path: str, body: dict | None = None) -> tuple[int, dict]:
        return self._call("POST", path, body or {})

    def _call(self, method: str, path: str, body: dict, auth: bool = True) -> tuple[int, dict]:
        headers = {"Content-Type": "application/json", **({"Authorization": f"Token {self.token}"} if auth else {})}
        request = urllib.request.Request(f"{self.url}{path}", data=json.dumps(body).encode(), method=method,
                                         headers=headers)
        try:
            with urllib.request.urlopen(request, timeout=10) as res:
                return res.status, json.loads(res.read())
        except urllib.error.HTTPError as err:
            return err.code, json.loads(err.read() or b"{}")


@contextlib.contextmanager
def online(stack: Stack) -> Iterator[Stack]:
    """``stack`` started, its robot online; stopped afterwards however the test ends."""
    try:
        stack.start()
        stack.wait_robot_online(timeout=40)
        yield stack
    finally:
        stack.stop()


@contextlib.contextmanager
def online_on_private_postgres() -> Iterator[Stack]:
    """An embedded stack, online, on a PostgreSQL of its own (``stack.postgres``) that a test may stop."""
    from tests.deploy.topology import PrivatePostgres, _as_postgres

    postgres = PrivatePostgres().start()
    try:
        subprocess.run(_as_postgres([str(postgres.bin / "psql"), "-h", "127.0.0.1", "-p", str(postgres.port), "-U",
                                     "postgres", "-c", "CREATE DATABASE cyborg"]), check=True, capture_output=True)
        running = Stack(env={"DATABASE_URL": postgres.url})
        running.postgres = postgres  # type: ignore[attr-defined]
        with online(running):
            yield running
    finally:
        postgres.remove()
