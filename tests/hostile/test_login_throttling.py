"""Guessing passwords: after LOGIN_FAILURE_LIMIT failures for one account or from one address,
the login form and the token endpoint refuse both (even the right password), the lockout is
audited, shown in the admin and cleared there."""

from __future__ import annotations

import asyncio

import pytest
from axes.models import AccessAttempt
from django.test import Client
from rest_framework.test import APIClient

from robot import interface as ri
from robot.models import AuditEntry
from tests.conftest import PASSWORD
from tests.helpers import async_wait_until

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


def test_failures_from_many_addresses_never_lock_an_operator_out_of_their_own(operator, viewer, settings):
    """Anyone could otherwise keep every operator from logging in to press the E-STOP. A flood
    from many addresses makes the account take a password only in a browser that logged in to it
    before: the guesser's never did; the operator's own did."""
    settings.LOGIN_FLOOD_LIMIT = 12
    own = Client(REMOTE_ADDR="10.0.0.9")
    assert own.post("/accounts/login/", {"username": "otto", "password": PASSWORD}).status_code == 302
    own.post("/accounts/logout/")
    for n in range(LIMIT * 3):
        form_login("otto", "wrong", address=f"10.5.5.{n}")
        token_login("otto", "wrong", address=f"10.4.4.{n}")
    assert own.post("/accounts/login/", {"username": "otto", "password": PASSWORD}).status_code == 302
    elsewhere = form_login("otto", PASSWORD, address="10.0.0.8")  # the right password, from a new browser
    assert elsewhere.status_code == 429 and "browser that has logged in to it before" in elsewhere.content.decode()
    script = token_login("otto", PASSWORD, address="10.0.0.8")
    assert script.status_code == 429 and script.json()["code"] == "locked_out"
    assert "browser that has logged in" in script.json()["detail"]
    assert form_login("vera", PASSWORD, address="10.0.0.7").status_code == 302  # other accounts as usual


def test_below_the_flood_limit_the_right_password_works_from_anywhere(operator, settings):
    settings.LOGIN_FLOOD_LIMIT = 100
    for n in range(LIMIT * 3):
        form_login("otto", "wrong", address=f"10.5.5.{n}")
    assert form_login("otto", PASSWORD, address="10.0.0.8").status_code == 302


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


CSRF = "c" * 32  # a CSRF secret of our own, as cookie and field (or header)


async def _asgi(method: str, path: str, *, peer: str, forwarded: str = "", form: str = "",
                cookies: dict[str, str] | None = None) -> tuple[int, dict[str, str]]:
    """A request through the whole ASGI application from ``peer`` (with that X-Forwarded-For):
    its status and the cookies it set."""
    from asgiref.testing import ApplicationCommunicator

    from server.asgi import application

    body = f"{form}&csrfmiddlewaretoken={CSRF}".encode() if form else b""
    jar = {"csrftoken": CSRF, **(cookies or {})}
    headers = [(b"host", b"127.0.0.1"), (b"content-type", b"application/x-www-form-urlencoded"),
               (b"cookie", "; ".join(f"{k}={v}" for k, v in jar.items()).encode()), (b"x-csrftoken", CSRF.encode()),
               (b"content-length", str(len(body)).encode())]
    if forwarded:
        headers.append((b"x-forwarded-for", forwarded.encode()))
    app = ApplicationCommunicator(application, {
        "type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": method, "scheme": "http",
        "path": path, "raw_path": path.encode(), "query_string": b"", "headers": headers,
        "client": (peer, 50000), "server": ("127.0.0.1", 8000)})
    await app.send_input({"type": "http.request", "body": body, "more_body": False})
    start = await app.receive_output(timeout=20)
    while (await app.receive_output(timeout=20)).get("more_body"):
        pass
    set_cookies = [v.decode().split(";", 1)[0] for k, v in start["headers"] if k.lower() == b"set-cookie"]
    return start["status"], dict(c.split("=", 1) for c in set_cookies)


async def _asgi_login(peer: str, forwarded: str, username: str, password: str) -> int:
    return (await _asgi("POST", "/accounts/login/", peer=peer, forwarded=forwarded,
                        form=f"username={username}&password={password}"))[0]


@pytest.mark.django_db(transaction=True)
async def test_an_operator_logs_in_and_presses_the_estop_during_a_flood_against_their_account(
        operator, settings, link, sim):
    """Guessing from many addresses at once, and meanwhile the operator, in their own browser,
    logs in and presses the E-STOP: it reaches the robot."""
    settings.TRUSTED_PROXIES = ["127.0.0.1/32"]
    settings.LOGIN_FLOOD_LIMIT = 10
    status, device = await _asgi_login_cookies("10.0.0.9", "otto", PASSWORD)  # an earlier day, same browser
    assert status == 302 and "cyborg_device" in device
    flooding = asyncio.Event()

    async def flood() -> int:
        sent = 0
        while not flooding.is_set():
            await _asgi_login("127.0.0.1", f"10.66.{sent // 250}.{sent % 250}", "otto", "guess")
            sent += 1
        return sent

    guesser = asyncio.ensure_future(flood())
    try:
        from dashboard.login_flood import failures_everywhere

        while await asyncio.to_thread(failures_everywhere, "otto") < settings.LOGIN_FLOOD_LIMIT:
            await asyncio.sleep(0.05)
        stranger = await _asgi_login("127.0.0.1", "10.0.0.8", "otto", PASSWORD)
        assert stranger == 429  # the right password from a browser the account never used
        status, cookies = await _asgi("POST", "/accounts/login/", peer="127.0.0.1", forwarded="10.0.0.9",
                                      form=f"username=otto&password={PASSWORD}",
                                      cookies={"cyborg_device": device["cyborg_device"]})
        assert status == 302, status
        before = len(await asyncio.to_thread(sim.received, ri.topic("cmd_vel").name))
        status, _ = await _asgi("POST", "/api/robot/estop/", peer="127.0.0.1", forwarded="10.0.0.9",
                                cookies={"sessionid": cookies["sessionid"]})
        assert status == 200, status
        await async_wait_until(lambda: len(sim.received(ri.topic("cmd_vel").name)) > before, timeout=5,
                               what="the E-STOP's zero at the robot")
    finally:
        flooding.set()
        sent = await guesser
    assert sent >= settings.LOGIN_FLOOD_LIMIT


async def _asgi_login_cookies(address: str, username: str, password: str) -> tuple[int, dict[str, str]]:
    return await _asgi("POST", "/accounts/login/", peer="127.0.0.1", forwarded=address,
                       form=f"username={username}&password={password}")


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
