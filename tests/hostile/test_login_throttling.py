"""Guessing passwords: after LOGIN_FAILURE_LIMIT failures for one account or from one address,
the login form and the token endpoint refuse both (even the right password), the lockout is
audited, shown in the admin and cleared there."""

from __future__ import annotations

import asyncio

import pytest
from axes.models import AccessAttempt
from django.test import Client
from rest_framework.test import APIClient

from robot.models import AuditEntry
from tests.conftest import PASSWORD

pytestmark = pytest.mark.django_db

LIMIT = 3


@pytest.fixture(autouse=True)
def _small_limit(settings):
    settings.AXES_FAILURE_LIMIT = LIMIT


def form_login(username: str, password: str, address: str = "10.0.0.1"):
    return Client(REMOTE_ADDR=address).post("/accounts/login/", {"username": username, "password": password})


def token_login(username: str, password: str, address: str = "10.0.0.1"):
    return APIClient(REMOTE_ADDR=address).post("/api/auth/token/", {"username": username, "password": password},
                                               format="json")


def test_the_login_form_locks_an_account_out_and_audits_it(operator):
    for _ in range(LIMIT - 1):
        assert form_login("otto", "wrong").status_code == 200
    locked = form_login("otto", "wrong")
    assert locked.status_code == 429
    assert "Too many failed logins" in locked.content.decode()
    # The right password from there does not get in either; from another address it does.
    assert form_login("otto", PASSWORD).status_code == 429
    assert form_login("otto", PASSWORD, address="10.0.0.2").status_code == 302
    entry = AuditEntry.objects.filter(action="login.lockout").first()
    assert entry is not None and (entry.ok, entry.error_code, entry.source) == (False, "locked_out", "page")
    assert entry.params["username"] == "otto"


def test_the_token_endpoint_locks_out_with_a_json_429(operator):
    for _ in range(LIMIT - 1):
        res = token_login("otto", "wrong")
        assert res.status_code == 400 and res.json()["code"] == "invalid"
    locked = token_login("otto", "wrong")
    assert locked.status_code == 429, locked.content
    assert locked.json()["code"] == "locked_out" and "Retry-After" in locked
    refused = token_login("otto", PASSWORD)
    assert refused.status_code == 429 and refused.json()["code"] == "locked_out"
    assert token_login("otto", PASSWORD, address="10.9.9.9").status_code == 200
    assert AuditEntry.objects.filter(action="login.lockout", source="api").exists()


def test_one_address_guessing_many_accounts_is_locked_out(operator, viewer):
    for name in ("a", "b", "c")[:LIMIT]:
        form_login(name, "wrong", address="10.6.6.6")
    assert form_login("vera", PASSWORD, address="10.6.6.6").status_code == 429
    assert token_login("vera", PASSWORD, address="10.6.6.6").status_code == 429
    # Another address is not affected, and the guessed account names were not real ones.
    assert form_login("vera", PASSWORD, address="10.7.7.7").status_code == 302


def test_failures_from_many_addresses_never_lock_an_operator_out_of_their_own(operator):
    """Anyone could otherwise keep every operator from logging in to press the E-STOP."""
    for n in range(LIMIT * 3):
        form_login("otto", "wrong", address=f"10.5.5.{n}")
        token_login("otto", "wrong", address=f"10.4.4.{n}")
    assert form_login("otto", PASSWORD, address="10.0.0.9").status_code == 302
    assert token_login("otto", PASSWORD, address="10.0.0.9").status_code == 200


def test_a_success_resets_the_account_count(operator):
    for _ in range(LIMIT - 1):
        form_login("otto", "wrong")
    assert form_login("otto", PASSWORD).status_code == 302
    for _ in range(LIMIT - 1):
        form_login("otto", "wrong", address="10.0.0.3")
    assert form_login("otto", PASSWORD, address="10.0.0.4").status_code == 302


def test_admins_see_and_clear_lockouts_in_the_admin(operator, admin_user):
    for _ in range(LIMIT):
        form_login("otto", "wrong")
    assert form_login("otto", PASSWORD).status_code == 429
    admin = Client()
    admin.force_login(admin_user)
    listing = admin.get("/admin/axes/accessattempt/")
    assert listing.status_code == 200 and "otto" in listing.content.decode()
    ids = [str(pk) for pk in AccessAttempt.objects.values_list("pk", flat=True)]
    cleared = admin.post("/admin/axes/accessattempt/", {"action": "delete_selected", "_selected_action": ids,
                                                         "post": "yes"})
    assert cleared.status_code == 302
    assert not AccessAttempt.objects.exists()
    assert form_login("otto", PASSWORD).status_code == 302


async def _asgi_login(peer: str, forwarded: str, username: str, password: str) -> int:
    """A form login through the whole ASGI application, from ``peer``, with that X-Forwarded-For."""
    from asgiref.testing import ApplicationCommunicator

    from cyborg_site.asgi import application

    csrf = "c" * 32  # a CSRF secret of our own, as cookie and field
    body = f"username={username}&password={password}&csrfmiddlewaretoken={csrf}".encode()
    headers = [(b"host", b"127.0.0.1"), (b"content-type", b"application/x-www-form-urlencoded"),
               (b"cookie", f"csrftoken={csrf}".encode()),
               (b"content-length", str(len(body)).encode()), (b"x-forwarded-for", forwarded.encode())]
    app = ApplicationCommunicator(application, {
        "type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": "POST", "scheme": "http",
        "path": "/accounts/login/", "raw_path": b"/accounts/login/", "query_string": b"", "headers": headers,
        "client": (peer, 50000), "server": ("127.0.0.1", 8000)})
    await app.send_input({"type": "http.request", "body": body, "more_body": False})
    start = await app.receive_output(timeout=10)
    while (await app.receive_output(timeout=10)).get("more_body"):
        pass
    return start["status"]


@pytest.mark.django_db(transaction=True)
async def test_only_a_trusted_proxy_names_the_client(operator, settings):
    """Failures through the proxy count against the address it added (forged ones before it are
    ignored); a client that is not the proxy cannot name an address at all."""
    settings.TRUSTED_PROXIES = ["127.0.0.1/32"]
    for n in range(LIMIT):  # rotating forged addresses, all from one real client
        await _asgi_login("127.0.0.1", f"1.2.3.{n}, 10.1.1.1", "nobody", "x")
    assert await _asgi_login("127.0.0.1", "6.6.6.6, 10.1.1.1", "otto", PASSWORD) == 429
    assert await _asgi_login("127.0.0.1", "10.2.2.2", "otto", PASSWORD) == 302  # another client of the proxy
    from axes.models import AccessAttempt

    counted = await asyncio.to_thread(lambda: set(AccessAttempt.objects.values_list("ip_address", flat=True)))
    assert counted <= {"10.1.1.1", "10.2.2.2"}
    for n in range(LIMIT):  # not the proxy: its header is ignored, its own address counts
        await _asgi_login("10.9.9.9", f"10.3.3.{n}", "nobody", "x")
    assert await _asgi_login("10.9.9.9", "10.4.4.4", "otto", PASSWORD) == 429
