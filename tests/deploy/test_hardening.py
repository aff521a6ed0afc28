"""The shipped nginx site and scripts/stack.sh's files, on the production topology: what nginx says
about itself, its TLS suites, its headers on static files, its :80 redirect, its request limits, and
which of the stack's files only their owner may read."""

from __future__ import annotations

import http.client
import json
import os
import re
import stat
import subprocess
from email.message import Message
from typing import NamedTuple

import pytest
from django.conf import settings

from tests.deploy.topology import _TLS, Topology, on_private_services

pytestmark = [
    pytest.mark.stack,
    pytest.mark.skipif(settings.EMBEDDED, reason="the production topology runs in the services pass"),
]
HSTS = "max-age=60; includeSubDomains; preload"  # the stack's (stack.sh shortens the site's year)


@pytest.fixture(scope="module")
def topology():
    with on_private_services() as topo:
        topo.script("up")
        yield topo


class Reply(NamedTuple):
    status: int
    headers: Message
    body: bytes

    def header(self, name: str) -> str | None:
        return self.headers.get(name)


def _get(topology: Topology, path: str, *, headers: dict[str, str] | None = None, https: bool = True,
         source: str = "127.0.0.1") -> Reply:
    """One request from ``source`` (any loopback address: nginx limits each address on its own)."""
    conn: http.client.HTTPConnection
    if https:
        conn = http.client.HTTPSConnection("127.0.0.1", topology.https_port, timeout=10, context=_TLS,
                                           source_address=(source, 0))
    else:
        conn = http.client.HTTPConnection("127.0.0.1", topology.http_port, timeout=10, source_address=(source, 0))
    conn.request("GET", path, headers={"Host": "localhost", **(headers or {})})
    try:
        response = conn.getresponse()
        return Reply(response.status, response.headers, response.read())
    finally:
        conn.close()


def _from_nginx(reply: Reply) -> bool:
    """nginx's own error page, not an answer of the application's."""
    return b"<center>nginx</center>" in reply.body


def _static_names(topology: Topology) -> tuple[str, str]:
    """A collected file's plain name and its content-hashed one."""
    manifest = json.loads((topology.dir / "var" / "staticfiles" / "staticfiles.json").read_text())
    plain, hashed = next((k, v) for k, v in manifest["paths"].items() if k.endswith(".js"))
    return plain, hashed


def test_nginx_never_says_its_version(topology):
    for response in (_get(topology, "/healthz"), _get(topology, "/static/no-such-file.css"),
                     _get(topology, "/", https=False)):
        assert response.header("Server") == "nginx", response.headers.items()
    missing = _get(topology, "/static/no-such-file.css")
    assert missing.status == 404 and _from_nginx(missing)
    assert not re.search(rb"nginx/\d", missing.body)


def test_static_files_carry_hsts_and_nosniff_with_their_caching(topology):
    plain, hashed = _static_names(topology)
    for name, caching in ((plain, "no-cache"), (hashed, "public, max-age=31536000, immutable")):
        response = _get(topology, f"/static/{name}")
        assert response.status == 200, name
        assert response.header("Strict-Transport-Security") == HSTS, (name, response.headers.items())
        assert response.header("X-Content-Type-Options") == "nosniff", (name, response.headers.items())
        assert response.header("Cache-Control") == caching, (name, response.headers.items())
    page = _get(topology, "/accounts/login/")
    assert page.status == 200
    # Django's own, once: nginx adds nothing to the application's answers.
    assert page.headers.get_all("Strict-Transport-Security") == [HSTS]
    assert page.headers.get_all("X-Content-Type-Options") == ["nosniff"]


def test_the_http_redirect_names_the_site_never_the_host_it_was_sent(topology):
    for host in ("localhost", "evil.example", f"evil.example:{topology.https_port}"):
        response = _get(topology, "/accounts/login/?next=/", https=False, headers={"Host": host})
        assert response.status == 301
        assert response.header("Location") == f"https://localhost:{topology.https_port}/accounts/login/?next=/"


def test_a_burst_of_logins_from_one_address_gets_429_from_nginx(topology):
    source = "127.0.0.2"
    statuses = []
    for _ in range(40):
        response = _get(topology, "/accounts/login/", source=source)
        statuses.append(response.status)
        if response.status == 429:
            assert _from_nginx(response)
    assert statuses[0] == 200 and 429 in statuses, statuses
    # One budget for every way in: the token endpoint is refused before Django, the rest is not.
    assert _from_nginx(token := _get(topology, "/api/auth/token/", source=source)) and token.status == 429
    assert _get(topology, "/admin/login/", source=source).status == 429
    assert _get(topology, "/healthz", source=source).status == 200
    # Another address has its own.
    assert _get(topology, "/accounts/login/", source="127.0.0.3").status == 200


def test_a_burst_of_socket_opens_from_one_address_gets_429_from_nginx(topology):
    upgrade = {"Connection": "Upgrade", "Upgrade": "websocket", "Sec-WebSocket-Version": "13",
               "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ=="}
    refused = [r for r in (_get(topology, "/ws/live/", headers=upgrade, source="127.0.0.4") for _ in range(60))
               if r.status == 429]
    assert refused and all(_from_nginx(r) for r in refused)


def _handshake(topology: Topology, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["openssl", "s_client", "-connect", f"127.0.0.1:{topology.https_port}",
                           "-servername", "localhost", *args],
                          input="", capture_output=True, text=True, timeout=30)


def test_tls_1_2_takes_only_forward_secret_aead_suites(topology):
    assert _handshake(topology, "-tls1_2", "-cipher", "ECDHE-RSA-AES128-GCM-SHA256").returncode == 0
    for suite in ("AES128-SHA", "AES256-SHA256", "AES128-GCM-SHA256", "ECDHE-RSA-AES128-SHA"):
        out = _handshake(topology, "-tls1_2", "-cipher", suite)
        assert out.returncode != 0 and "handshake failure" in out.stderr, (suite, out.stdout[-500:], out.stderr)
    assert _handshake(topology, "-tls1_3").returncode == 0


def test_the_secrets_the_stack_writes_only_their_owner_may_read(topology):
    setup_log = topology.dir / "logs" / "setup.log"
    assert "Created the first admin" in setup_log.read_text()
    for path in (topology.dir / "cyborg.env", setup_log, topology.dir / "tls" / "privkey.pem"):
        mode = stat.S_IMODE(os.stat(path).st_mode)
        assert mode == 0o600, f"{path} is {mode:o}"
