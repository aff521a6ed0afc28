"""A real network boundary for the uplink: the robot's computer as a network namespace.

``RobotSide`` is a namespace joined to this machine by a veth pair (10.231.N.0/30): what runs in it
has its own loopback, reaches the server at ``host_ip`` and cannot be reached except through ports
it binds on ``robot_ip``. ``TestCA`` signs the server's certificate; ``Front`` is nginx with TLS on
``host_ip`` carrying the shipped site's ``/uplink/`` location to the server's uplink endpoint.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path

from tests.stack import ROOT, wait_for_port


def _ip(*args: str, check: bool = True) -> None:
    subprocess.run(["ip", *args], check=check, capture_output=True, timeout=10)


def worker_number() -> int:
    return int(os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw")) % 200


class RobotSide:
    def __init__(self) -> None:
        n = worker_number()
        self.name = f"cyb-uplink-{n}"
        self.host_if, self.robot_if = f"cyu{n}h", f"cyu{n}r"
        self.host_ip, self.robot_ip = f"10.231.{n}.1", f"10.231.{n}.2"

    def up(self) -> RobotSide:
        self.down()
        _ip("netns", "add", self.name)
        _ip("link", "add", self.host_if, "type", "veth", "peer", "name", self.robot_if)
        _ip("link", "set", self.robot_if, "netns", self.name)
        _ip("addr", "add", f"{self.host_ip}/30", "dev", self.host_if)
        _ip("link", "set", self.host_if, "up")
        for args in (("addr", "add", f"{self.robot_ip}/30", "dev", self.robot_if),
                     ("link", "set", self.robot_if, "up"), ("link", "set", "lo", "up")):
            _ip("netns", "exec", self.name, "ip", *args)
        return self

    def down(self) -> None:
        _ip("netns", "del", self.name, check=False)
        _ip("link", "del", self.host_if, check=False)

    def prefix(self) -> tuple[str, ...]:
        return ("ip", "netns", "exec", self.name)

    def spawn(self, args: list[str], log: Path, env: dict[str, str]) -> subprocess.Popen:
        return subprocess.Popen([*self.prefix(), *args], cwd=ROOT, env=env, stdout=open(log, "a"),
                                stderr=subprocess.STDOUT, start_new_session=True)

    def fetch(self, url: str) -> bytes:
        """GET ``url`` from inside the robot's computer."""
        return subprocess.run([*self.prefix(), "curl", "-sSf", "--max-time", "5", url], check=True,
                              capture_output=True, timeout=20).stdout

    def wait_port(self, port: int, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            probe = subprocess.run([*self.prefix(), "bash", "-c", f"exec 3<>/dev/tcp/127.0.0.1/{port}"],
                                   capture_output=True, timeout=10)
            if probe.returncode == 0:
                return
            time.sleep(0.2)
        raise RuntimeError(f"nothing listens on the robot's port {port}")


class TestCA:
    __test__ = False

    """A CA of the tests' own and a certificate for ``ip`` signed by it."""

    def __init__(self, ip: str) -> None:
        self.dir = Path(tempfile.mkdtemp(prefix="cyborg-uplink-ca-"))
        self.ca, self.cert, self.key = self.dir / "ca.pem", self.dir / "cert.pem", self.dir / "key.pem"

        def openssl(*args: str) -> None:
            subprocess.run(["openssl", *args], check=True, capture_output=True, cwd=self.dir, timeout=60)

        openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes", "-days", "2",
                "-subj", "/CN=Cyborg test CA", "-keyout", "ca-key.pem", "-out", str(self.ca))
        openssl("req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes", "-subj", f"/CN={ip}",
                "-keyout", str(self.key), "-out", "cert.csr")
        (self.dir / "ext.cnf").write_text(f"subjectAltName=IP:{ip}\n")
        openssl("x509", "-req", "-in", "cert.csr", "-CA", str(self.ca), "-CAkey", "ca-key.pem", "-CAcreateserial",
                "-days", "2", "-extfile", "ext.cnf", "-out", str(self.cert))

    def remove(self) -> None:
        shutil.rmtree(self.dir, ignore_errors=True)


def _site() -> str:
    return (ROOT / "deploy" / "nginx" / "cyborg.conf").read_text()


def site_location(path: str) -> str:
    """The shipped site's ``location PATH { … }`` block, as it is."""
    found = re.search(rf"\n    location {re.escape(path)} \{{.*?\n    \}}\n", _site(), re.S)
    assert found, f"deploy/nginx/cyborg.conf has no location {path}"
    return found.group(0)


def uplink_location() -> str:
    """The shipped site's ``/uplink/`` location, as it is (but for its per-address limit)."""
    return site_location("= /uplink/").replace("limit_req zone=cyborg_login burst=5 nodelay;", "")


def web_locations(web_port: int) -> tuple[str, str]:
    """The shipped site's limits (for the http block) and its locations for the pages and their sockets
    (for the server), to ``web_port``."""
    site = _site()
    zones = "\n".join(line for line in site.splitlines() if line.startswith(("limit_req_zone", "limit_conn_zone")))
    return (f"{zones}\nupstream cyborg_web {{ server 127.0.0.1:{web_port} max_fails=0; }}\n",
            "limit_req_status 429; limit_conn_status 429; client_max_body_size 20m;\n"
            + site_location("/ws/") + site_location("/"))


class Front:
    """nginx on ``ip``:``port`` with TLS, ``/uplink/`` to ``uplink_port``; with ``web_port``, also the
    site's pages and sockets to that Daphne, and the same server on 127.0.0.1:``port`` for a browser
    here (``web_url``; the stack needs ``web_env()``)."""

    def __init__(self, *, ip: str, port: int, uplink_port: int, ca: TestCA, web_port: int | None = None) -> None:
        self.dir = Path(tempfile.mkdtemp(prefix="cyborg-uplink-nginx-"))
        self.ip, self.port = ip, port
        http_extra, server_extra, listen_extra = "", "", ""
        if web_port is not None:
            http_extra, server_extra = web_locations(web_port)
            listen_extra = f"listen 127.0.0.1:{port} ssl;"
        # (as root, nginx's worker would run as nobody: it could not use the temporary folders here)
        user = "user root;" if os.geteuid() == 0 else ""
        (self.dir / "nginx.conf").write_text(f"""
daemon off;
{user}
worker_processes 1;
pid {self.dir}/nginx.pid;
error_log {self.dir}/error.log warn;
events {{ worker_connections 256; }}
http {{
    access_log {self.dir}/access.log;
    client_body_temp_path {self.dir}; proxy_temp_path {self.dir};
    fastcgi_temp_path {self.dir}; uwsgi_temp_path {self.dir}; scgi_temp_path {self.dir};
    map $http_upgrade $cyborg_connection {{ default upgrade; "" ""; }}
    upstream cyborg_uplink {{ server 127.0.0.1:{uplink_port} max_fails=0; }}
    {http_extra}
    server {{
        listen {ip}:{port} ssl;
        {listen_extra}
        ssl_certificate {ca.cert};
        ssl_certificate_key {ca.key};
        {uplink_location()}
        {server_extra}
    }}
}}
""")
        self.proc: subprocess.Popen | None = None

    @property
    def web_url(self) -> str:
        return f"https://127.0.0.1:{self.port}"

    def web_env(self) -> dict[str, str]:
        """What the server needs behind this nginx: its origin trusted, and TLS as nginx says."""
        return {"CSRF_TRUSTED_ORIGINS": self.web_url, "SECURE_PROXY_SSL_HEADER": "HTTP_X_FORWARDED_PROTO,https"}

    def start(self) -> Front:
        nginx = shutil.which("nginx") or "/usr/sbin/nginx"
        self.proc = subprocess.Popen([nginx, "-p", str(self.dir), "-c", str(self.dir / "nginx.conf")],
                                     stdout=subprocess.DEVNULL, stderr=open(self.dir / "stderr.log", "w"),
                                     start_new_session=True)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            try:
                urllib.request.urlopen(f"http://{self.ip}:{self.port}/", timeout=0.5)
            except urllib.error.HTTPError:
                return self  # (plain HTTP to a TLS port: nginx answers 400)
            except OSError:
                if self.proc.poll() is not None:
                    raise RuntimeError((self.dir / "stderr.log").read_text()) from None
                time.sleep(0.05)
        raise RuntimeError("nginx did not start")

    def kill(self) -> None:
        """nginx and its worker gone at once: every connection through it drops."""
        assert self.proc is not None
        os.killpg(self.proc.pid, signal.SIGKILL)
        self.proc.wait(5)

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            self.proc.wait(5)
        shutil.rmtree(self.dir, ignore_errors=True)


__all__ = ["Front", "RobotSide", "TestCA", "wait_for_port"]
