"""Alerts beyond the tab, each against a real counterpart: Django's outbox and a real SMTP server
process (aiosmtpd), a real local HTTP server as a chat tool's webhook, and a local push service
stand-in whose payload the test decrypts with the subscription's own keys (RFC 8291)."""

from __future__ import annotations

import asyncio
import base64
import json
import mailbox
import os
import subprocess
import sys
import time

import http_ece
import pytest
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec, utils
from django.core import mail

from robot.alerts import delivery, push
from robot.alerts.book import Record
from robot.alerts.models import AlertChoice, PushSubscription, Webhook
from tests.stack import free_port, wait_for_port

pytestmark = pytest.mark.django_db(transaction=True)


def a_record(kind: str = "battery_low", severity: str = "warning", text: str = "Battery low: 15 %") -> Record:
    now = time.time()
    return Record(key=kind, kind=kind, severity=severity, text=text, started_at=now, updated_at=now)


async def run_once(record: Record, until, timeout: float = 10.0) -> None:
    """The delivery worker as it runs where the link does, given one alert; until() says it is done."""
    worker = asyncio.ensure_future(delivery.run_delivery(None))  # it never uses the link itself
    await asyncio.sleep(0)
    delivery.offer(record)
    try:
        deadline = time.monotonic() + timeout
        while not until():
            assert time.monotonic() < deadline, "not delivered in time"
            await asyncio.sleep(0.05)
    finally:
        worker.cancel()
        await asyncio.gather(worker, return_exceptions=True)


@pytest.fixture
def otto_by_email(operator):
    operator.email = "otto@example.org"
    operator.save()
    AlertChoice.objects.create(user=operator, by_email=True, kinds=["battery_low", "estop"], min_severity="warning")
    return operator


async def test_it_mails_those_who_chose_the_kind_and_no_one_else(otto_by_email, viewer):
    await AlertChoice.objects.acreate(user=viewer, by_email=True, kinds=["log"])  # but no e-mail address
    await run_once(a_record(), lambda: len(mail.outbox) == 1)
    assert mail.outbox[0].to == ["otto@example.org"]
    assert mail.outbox[0].subject == "[Cyborg] warning: Battery low: 15 %"
    assert "Began: " in mail.outbox[0].body
    assert await asyncio.to_thread(delivery.recipients, "log", "error") == []
    assert [t.address for t in await asyncio.to_thread(delivery.recipients, "estop", "critical")] == \
        ["otto@example.org"]


@pytest.fixture
def smtp_server(tmp_path):
    port = free_port()
    box = tmp_path / "maildir"
    proc = subprocess.Popen([sys.executable, "-m", "aiosmtpd", "-n", "-l", f"127.0.0.1:{port}",
                             "-c", "aiosmtpd.handlers.Mailbox", str(box)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for_port(port, proc=proc)
        yield port, box
    finally:
        proc.terminate()
        proc.wait(10)


async def test_it_sends_mail_through_a_real_smtp_server(otto_by_email, smtp_server, settings):
    port, box = smtp_server
    settings.EMAIL_BACKEND = "django.core.mail.backends.smtp.EmailBackend"
    settings.EMAIL_HOST, settings.EMAIL_PORT = "127.0.0.1", port

    def received():
        return list(mailbox.Maildir(str(box), create=False)) if box.exists() else []

    await run_once(a_record(), lambda: len(received()) == 1)
    message = received()[0]
    assert message["To"] == "otto@example.org" and message["Subject"] == "[Cyborg] warning: Battery low: 15 %"


async def test_a_webhook_gets_json_and_a_failing_one_is_tried_again(http_server, monkeypatch):
    port = http_server.server_address[1]
    await Webhook.objects.acreate(name="chat", url=f"http://127.0.0.1:{port}/hook", kinds=["estop"])
    await Webhook.objects.acreate(name="off", url=f"http://127.0.0.1:{port}/off", enabled=False)
    monkeypatch.setattr(delivery, "deliver", _quick(delivery.deliver))
    http_server.statuses = [503]  # the chat tool is down for a moment
    record = a_record("estop", "critical", "E-STOP engaged by olga")
    await run_once(record, lambda: len(http_server.received) == 2)
    assert [path for path, _, _ in http_server.received] == ["/hook", "/hook"]
    body = json.loads(http_server.received[-1][2])
    assert body["text"].startswith("[critical] E-STOP engaged by olga (since ")
    assert body["alert"]["id"] == record.id and body["alert"]["kind"] == "estop"

    http_server.received.clear()
    http_server.statuses = [404]  # a 4xx is not tried again
    await run_once(a_record("estop", "critical"), lambda: len(http_server.received) == 1)
    await asyncio.sleep(0.5)
    assert len(http_server.received) == 1


def _quick(deliver):
    async def quick(target, record, gate):
        return await deliver(target, record, gate, backoff_s=0.05)
    return quick


def b64(raw: bytes) -> str:
    return base64.urlsafe_b64encode(raw).rstrip(b"=").decode()


async def test_web_push_is_encrypted_for_the_subscription_and_signed_with_the_servers_key(
        http_server, operator, settings, tmp_path):
    settings.VAPID_PRIVATE_KEY_FILE = str(tmp_path / "vapid.pem")
    push._key = None
    browser_key = ec.generate_private_key(ec.SECP256R1())
    auth = os.urandom(16)
    p256dh = browser_key.public_key().public_bytes(serialization.Encoding.X962,
                                                   serialization.PublicFormat.UncompressedPoint)
    port = http_server.server_address[1]
    await AlertChoice.objects.acreate(user=operator, by_push=True, kinds=["log"], min_severity="error")
    await PushSubscription.objects.acreate(user=operator, endpoint=f"http://127.0.0.1:{port}/push/abc",
                                           p256dh=b64(p256dh), auth=b64(auth))
    record = a_record("log", "critical", "FATAL from /move_base: planner crashed")
    await run_once(record, lambda: len(http_server.received) == 1)
    path, headers, body = http_server.received[0]
    assert path == "/push/abc" and headers["content-encoding"] == "aes128gcm"
    assert headers["authorization"].startswith("vapid t=") and f"k={push.public_key()}" in headers["authorization"]
    token = headers["authorization"].removeprefix("vapid t=").split(",")[0]
    signed, signature = token.rsplit(".", 1)
    raw = base64.urlsafe_b64decode(signature + "==")
    der = utils.encode_dss_signature(int.from_bytes(raw[:32], "big"), int.from_bytes(raw[32:], "big"))
    push.vapid().public_key.verify(der, signed.encode(), ec.ECDSA(hashes.SHA256()))  # raises if forged
    claims = json.loads(base64.urlsafe_b64decode(signed.split(".")[1] + "=="))
    assert claims["aud"] == f"http://127.0.0.1:{port}" and claims["sub"] == settings.VAPID_SUBJECT
    plain = http_ece.decrypt(body, private_key=browser_key, auth_secret=auth, version="aes128gcm")
    assert json.loads(plain) == delivery.payload(record)

    # The push service says the subscription is gone: it is forgotten.
    http_server.received.clear()
    http_server.statuses = [410]
    await run_once(a_record("log", "error", "ERROR again"), lambda: len(http_server.received) == 1)
    for _ in range(50):
        if not await PushSubscription.objects.aexists():
            break
        await asyncio.sleep(0.05)
    assert not await PushSubscription.objects.aexists()
    push._key = None
