"""The client address and scheme a trusted proxy vouches for, and nobody else."""

from __future__ import annotations

from cyborg_site.client_address import behind_proxy, is_trusted_proxy


def _scope(peer: str, kind: str = "http", **headers: str) -> dict:
    return {"type": kind, "scheme": "http" if kind == "http" else "ws", "client": (peer, 40000),
            "headers": [(k.replace("_", "-").encode(), v.encode()) for k, v in headers.items()]}


def test_a_trusted_proxy_names_the_client_and_scheme(settings):
    settings.TRUSTED_PROXIES = ["127.0.0.1", "fd00::/8"]
    scope = behind_proxy(_scope("127.0.0.1", x_forwarded_for="6.6.6.6, 10.0.0.7", x_forwarded_proto="https"))
    assert scope["client"] == ("10.0.0.7", 0) and scope["scheme"] == "https"
    ws = behind_proxy(_scope("fd00::1", "websocket", x_forwarded_for="10.0.0.8", x_forwarded_proto="https"))
    assert ws["client"] == ("10.0.0.8", 0) and ws["scheme"] == "wss"


def test_anyone_else_cannot_name_an_address(settings):
    settings.TRUSTED_PROXIES = ["127.0.0.1"]
    original = _scope("10.9.9.9", x_forwarded_for="127.0.0.1", x_forwarded_proto="https")
    assert behind_proxy(original) is original
    settings.TRUSTED_PROXIES = []
    assert not is_trusted_proxy("127.0.0.1")


def test_a_proxy_request_without_the_header_keeps_the_proxys_address(settings):
    settings.TRUSTED_PROXIES = ["127.0.0.0/8"]
    scope = behind_proxy(_scope("127.0.0.1", x_forwarded_proto="nonsense"))
    assert scope["client"] == ("127.0.0.1", 40000) and scope["scheme"] == "http"
    assert not is_trusted_proxy("not an address")
