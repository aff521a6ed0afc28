"""The production topology as real processes (scripts/stack.sh) on private Redis and PostgreSQL servers.

Fault tests stop and start these private servers for real; the machine's own never are.
Used by tests/deploy and bench/failover.py.
"""

from __future__ import annotations

import contextlib
import glob
import http.cookiejar
import json
import os
import re
import shutil
import signal
import ssl
import subprocess
import tempfile
import time
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Iterator
from pathlib import Path

from tests.stack import PASSWORD, PYTHON, ROOT, USERS, free_port
from tests.support_processes import PrivateRedis

LEASE = "link-lease"
_TLS = ssl.create_default_context()
_TLS.check_hostname = False
_TLS.verify_mode = ssl.CERT_NONE


def _json(body: bytes) -> dict:
    try:
        return json.loads(body or b"{}")
    except ValueError:
        return {"not_json": body[:300].decode(errors="replace")}


def _as_postgres(args: list[str]) -> list[str]:
    """PostgreSQL refuses to run as root: drop to the postgres user then."""
    return ["runuser", "-u", "postgres", "--", *args] if os.geteuid() == 0 else args


class PrivatePostgres:
    """initdb into a temporary folder and run Debian's postgres binaries on a free port."""

    def __init__(self) -> None:
        found = sorted(glob.glob("/usr/lib/postgresql/*/bin/pg_ctl"))
        if not found:
            raise RuntimeError("no PostgreSQL server binaries under /usr/lib/postgresql/*/bin")
        self.bin = Path(found[-1]).parent
        self.port = free_port()
        self.tmp = Path(tempfile.mkdtemp(prefix="cyborg-pg-"))
        self.data = self.tmp / "data"
        if os.geteuid() == 0:
            shutil.chown(self.tmp, "postgres")

    @property
    def url(self) -> str:
        return f"postgres://postgres@127.0.0.1:{self.port}/cyborg"

    def start(self) -> PrivatePostgres:
        if not self.data.exists():
            subprocess.run(_as_postgres([str(self.bin / "initdb"), "-D", str(self.data), "-U", "postgres",
                                         "--auth=trust", "-E", "UTF8", "--no-sync"]),
                           check=True, capture_output=True, timeout=120)
        subprocess.run(_as_postgres([
            str(self.bin / "pg_ctl"), "-D", str(self.data), "-l", str(self.tmp / "postgres.log"), "-w", "-t", "60",
            "-o", f"-p {self.port} -k {self.tmp} -c listen_addresses=127.0.0.1 -c fsync=off "
                  "-c synchronous_commit=off -c full_page_writes=off", "start"]),
            check=True, capture_output=True, timeout=90)
        return self

    def stop(self, mode: str = "fast") -> None:
        subprocess.run(_as_postgres([str(self.bin / "pg_ctl"), "-D", str(self.data), "-m", mode, "-w", "stop"]),
                       capture_output=True, timeout=60)

    def remove(self) -> None:
        self.stop("immediate")
        shutil.rmtree(self.tmp, ignore_errors=True)


class Topology:
    """scripts/stack.sh with free ports, a temporary folder and the given services."""

    redis: PrivateRedis  # the private services of on_private_services()
    postgres: PrivatePostgres

    def __init__(self, *, redis_url: str, database_url: str, env: dict[str, str] | None = None) -> None:
        self.dir = Path(tempfile.mkdtemp(prefix="cyborg-topology-"))
        self.https_port, self.http_port = free_port(), free_port()
        self.web_ports = (free_port(), free_port())
        self.prefix = f"cyborg-topology-{os.getpid()}"
        self.redis_url = redis_url
        extra = {"ROBOT_LINK_MAX_BACKOFF_S": "1", **(env or {})}
        self.env = {
            **{k: v for k, v in os.environ.items() if not k.startswith(("DJANGO_", "PYTEST_"))},
            "STACK_DIR": str(self.dir), "STACK_HTTPS_PORT": str(self.https_port),
            "STACK_HTTP_PORT": str(self.http_port), "STACK_WEB_PORTS": " ".join(map(str, self.web_ports)),
            "STACK_SIM_PORT": str(free_port()), "STACK_VIDEO_PORT": str(free_port()),
            "STACK_LINK_PORTS": f"127.0.0.1:{free_port()},127.0.0.1:{free_port()}",
            "REDIS_URL": redis_url, "DATABASE_URL": database_url, "CHANNEL_LAYER_PREFIX": self.prefix,
            "STACK_ENV": "\n".join(f"{k}={v}" for k, v in extra.items()),
        }
        self.env.pop("ROSBRIDGE_URL", None)
        self.tokens: dict[str, str] = {}

    @property
    def url(self) -> str:
        return f"https://localhost:{self.https_port}"

    def script(self, command: str, timeout: float = 180) -> str:
        """Run stack.sh; what it said on stderr (e.g. that a process ignored SIGTERM and was killed)."""
        out = subprocess.run(["bash", "scripts/stack.sh", *command.split()], cwd=ROOT, env=self.env,
                             capture_output=True, text=True, timeout=timeout)
        if out.returncode != 0:
            raise RuntimeError(f"stack.sh {command} exited with {out.returncode}:\n{out.stdout[-2000:]}\n"
                               f"{out.stderr[-3000:]}\n{self.logs()}")
        return out.stderr

    def up(self) -> Topology:
        self.script("up")
        for name, role in USERS.items():
            self.manage("adduser", name, "--role", role, "--password", PASSWORD)
        return self

    def down(self) -> None:
        try:
            self.script("down", timeout=120)
        finally:
            shutil.rmtree(self.dir, ignore_errors=True)

    def manage(self, *args: str) -> str:
        env = {**self.env, **self.stack_env()}
        return subprocess.run([PYTHON, "manage.py", *args], cwd=ROOT, env=env, check=True, capture_output=True,
                              text=True, timeout=120).stdout

    def stack_env(self) -> dict[str, str]:
        lines = (self.dir / "cyborg.env").read_text().splitlines()
        return dict(line.split("=", 1) for line in lines if "=" in line and not line.startswith("#"))

    # --- processes ---------------------------------------------------------------------

    def pid(self, name: str) -> int:
        return int((self.dir / "pids" / f"{name}.pid").read_text())

    def alive(self, name: str) -> bool:
        try:
            os.kill(self.pid(name), 0)
        except (ProcessLookupError, FileNotFoundError):
            return False
        return Path(f"/proc/{self.pid(name)}/status").read_text().find("State:\tZ") < 0

    def kill(self, name: str, sig: int = signal.SIGKILL) -> None:
        """The whole of NAME, its keeper too: it stays down (until ``restart``)."""
        os.killpg(self.pid(name), sig)

    def child(self, name: str) -> int:
        """The process NAME's keeper runs now (a new one after each death)."""
        return int((self.dir / "pids" / f"{name}.child").read_text())

    def crash(self, name: str, sig: int = signal.SIGKILL) -> int:
        """Kill the process NAME runs, as a crash would (its keeper starts it again); its pid."""
        pid = self.child(name)
        os.kill(pid, sig)
        return pid

    def log(self, name: str) -> str:
        path = self.dir / "logs" / f"{name}.log"
        return path.read_text(errors="replace") if path.exists() else ""

    def logs(self) -> str:
        return "\n".join(f"--- {p.name}\n{p.read_text(errors='replace')[-1500:]}"
                         for p in sorted((self.dir / "logs").glob("*.log")))

    def started(self, name: str) -> int:
        """How many times the link ``name`` has come up as standby (its log says so each time)."""
        return self.log(name).count("standby, waiting for the lease")

    def active_link(self) -> str | None:
        """The name of the link holding the lease (its token starts with the holder's name)."""
        import redis

        try:
            token = redis.Redis.from_url(self.redis_url, socket_timeout=1).get(f"{self.prefix}:{LEASE}")
        except redis.RedisError:
            return None
        return token.decode().split(":", 1)[0] if token else None

    def store_entry(self, key: str) -> dict:
        """One entry of the latest-state store ({} when absent or Redis is down)."""
        import redis

        try:
            raw = redis.Redis.from_url(self.redis_url, socket_timeout=0.5).hget(f"{self.prefix}:latest-state", key)
        except redis.RedisError:
            return {}
        return json.loads(raw) if raw else {}

    def received(self, topic: str) -> list[dict]:
        """Every message the simulator received on ``topic`` (its own record, the robot's side)."""
        query = urllib.parse.urlencode({"topic": topic, "last": 10_000})
        url = f"http://127.0.0.1:{self.env['STACK_VIDEO_PORT']}/sim/received?{query}"
        with urllib.request.urlopen(url, timeout=5) as res:
            return [m["msg"] for m in json.loads(res.read())["messages"]]

    def record_every(self, topic: str, msg_type: str) -> None:
        """Record every message of ``topic`` from now on. Until now the default policy sampled it (once a
        second for odometry): those rows leave gaps no recorder lost, so they go. Both links' samplers
        take the new policy within a second or two; what is recorded from then on is whole."""
        self.manage("shell", "-c", "from history.policies import policy_upsert\n"
                    f"policy_upsert(topic={topic!r}, msg_type={msg_type!r}, mode='every')")
        time.sleep(3)
        self.manage("shell", "-c", "import datetime\nfrom history.models import Sample\n"
                    "since = datetime.datetime.now(datetime.UTC) - datetime.timedelta(seconds=1)\n"
                    f"Sample.objects.filter(topic={topic!r}, received_at__lt=since).delete()")

    def recorded_seqs(self, database_url: str, topic: str) -> list[int]:
        """header.seq of every recorded message of ``topic``, in order."""
        import psycopg

        with psycopg.connect(database_url.replace("postgres://", "postgresql://"), connect_timeout=5) as conn:
            rows = conn.execute("SELECT (data->'header'->>'seq')::bigint FROM history_sample WHERE topic = %s "
                                "ORDER BY 1", [topic]).fetchall()
        return [seq for (seq,) in rows]

    # --- HTTP through nginx, or straight to one web process -----------------------------

    def fetch(self, path: str, *, web: int | None = None, method: str = "GET", body: dict | None = None,
              user: str | None = None, timeout: float = 5) -> tuple[int, dict]:
        base = self.url if web is None else f"http://127.0.0.1:{self.web_ports[web]}"
        headers = {"Content-Type": "application/json", "Host": "localhost"}
        if web is not None:
            headers["X-Forwarded-Proto"] = "https"  # what nginx says; Django trusts it (SECURE_PROXY_SSL_HEADER)
        if user is not None:
            headers["Authorization"] = f"Token {self.token(user)}"
        data = json.dumps(body).encode() if body is not None else None
        request = urllib.request.Request(base + path, data=data, headers=headers, method=method)
        try:
            with urllib.request.urlopen(request, timeout=timeout, context=_TLS) as res:
                return res.status, _json(res.read())
        except urllib.error.HTTPError as err:
            return err.code, _json(err.read())

    def login_cookie(self, username: str) -> str:
        """Log in through nginx with the form, like a browser; the Cookie header."""
        jar = http.cookiejar.CookieJar()
        opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor(jar),
                                             urllib.request.HTTPSHandler(context=_TLS))
        page = opener.open(f"{self.url}/accounts/login/", timeout=10).read().decode()
        csrf = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page).group(1)  # type: ignore[union-attr]
        form = urllib.parse.urlencode({"username": username, "password": PASSWORD, "csrfmiddlewaretoken": csrf})
        opener.open(urllib.request.Request(f"{self.url}/accounts/login/", data=form.encode(),
                                           headers={"Referer": f"{self.url}/accounts/login/"}), timeout=10).read()
        return "; ".join(f"{c.name}={c.value}" for c in jar)

    def token(self, user: str) -> str:
        if user not in self.tokens:
            status, body = self.fetch("/api/auth/token/", method="POST",
                                      body={"username": user, "password": PASSWORD})
            assert status == 200, body
            self.tokens[user] = body["token"]
        return self.tokens[user]

    def health(self, web: int | None = None, *, details: bool = False) -> dict:
        """/healthz as anyone sees it, or with the details an admin's token gets."""
        try:
            return self.fetch("/healthz", web=web, user="ada" if details else None, timeout=2)[1]
        except OSError:
            return {}

    def wait(self, condition, *, timeout: float = 30, what: str = "the condition", every: float = 0.05) -> float:
        """Wait until ``condition()`` is true; returns the seconds it took."""
        started = time.monotonic()
        while not condition():
            if time.monotonic() - started > timeout:
                raise AssertionError(f"{what} not within {timeout} s\n{self.logs()}")
            time.sleep(every)
        return time.monotonic() - started


@contextlib.contextmanager
def on_private_services(env: dict[str, str] | None = None) -> Iterator[Topology]:
    """A topology (not started) on a private redis-server and PostgreSQL of its own, which a test
    may stop and start (``topology.redis``, ``topology.postgres``); all taken down after."""
    redis = PrivateRedis().start()
    postgres = PrivatePostgres().start()
    topo = Topology(redis_url=redis.url, database_url=postgres.url, env=env)
    topo.redis, topo.postgres = redis, postgres
    try:
        yield topo
    finally:
        try:
            topo.down()
        finally:
            redis.stop()
            postgres.remove()
