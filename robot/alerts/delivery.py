"""Alerts beyond the tab: e-mail, Web Push and webhooks, sent from where the alerts are raised.

A new alert is queued (never waited for); one worker finds who wants it (each person's
AlertChoice, the admins' webhooks) and sends to each on a thread of its own, at most
``PARALLEL`` at a time, tried ``ATTEMPTS`` times with a growing wait. Nothing here touches the
robot's path: a slow mail server or chat tool only delays its own message.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any
from zoneinfo import ZoneInfo

import requests
from asgiref.sync import sync_to_async
from django.conf import settings
from django.core.mail import send_mail

from robot.alerts import push
from robot.alerts.book import Record
from robot.alerts.models import AlertChoice, PushSubscription, Webhook
from robot.link.hosting import register_background
from robot.supervisor import Tasks, holding, running

if TYPE_CHECKING:
    from robot.link.connection import RobotLink

log = logging.getLogger(__name__)

ATTEMPTS = 3
PARALLEL = 4
MAX_QUEUED = 500
WEBHOOK_TIMEOUT_S = 5.0


class Permanent(Exception):
    """Trying again will not help (a webhook's 4xx, a subscription gone)."""


@dataclass(frozen=True)
class Target:
    channel: str  # email | push | webhook
    address: Any  # an e-mail address, a push subscription, a webhook URL
    subscription_id: int | None = None


def payload(record: Record) -> dict[str, Any]:
    return {"id": record.id, "kind": record.kind, "severity": record.severity, "text": record.text,
            "started_at": record.started_at, "count": record.count}


def recipients(kind: str, severity: str) -> list[Target]:
    """Everyone who asked for this kind and severity, by the ways they chose; then the webhooks."""
    out: list[Target] = []
    for choice in AlertChoice.objects.select_related("user").filter(user__is_active=True):
        if not choice.wants(kind, severity):
            continue
        if choice.by_email and choice.address:
            out.append(Target("email", choice.address))
        if choice.by_push:
            out += [Target("push", {"endpoint": s.endpoint, "keys": {"p256dh": s.p256dh, "auth": s.auth}}, s.id)
                    for s in PushSubscription.objects.filter(user=choice.user)]
    out += [Target("webhook", hook.url) for hook in Webhook.objects.filter(enabled=True) if hook.wants(kind, severity)]
    return out


def _began(record: Record) -> str:
    when = datetime.fromtimestamp(record.started_at, UTC).astimezone(ZoneInfo(settings.TIME_ZONE))
    return when.strftime("%Y-%m-%d %H:%M:%S %Z")


def send_email(address: str, record: Record) -> None:
    send_mail(f"[Cyborg] {record.severity}: {record.text}"[:200],
              f"{record.text}\n\nSeverity: {record.severity}\nBegan: {_began(record)}\n",
              None, [address], fail_silently=False)


def send_webhook(url: str, record: Record) -> None:
    # "text" is what chat tools (Slack, Mattermost, Teams' incoming webhooks) show.
    body: dict[str, Any] = {"text": f"[{record.severity}] {record.text} (since {_began(record)})",
                            "alert": payload(record)}
    res = requests.post(url, json=body, timeout=WEBHOOK_TIMEOUT_S)
    if 400 <= res.status_code < 500 and res.status_code != 429:
        raise Permanent(f"{url} answered {res.status_code}")
    res.raise_for_status()


def send_push(subscription: dict[str, Any], record: Record) -> None:
    try:
        push.send(subscription, payload(record))
    except push.Gone as exc:
        raise Permanent(f"push subscription gone: {exc}") from exc


SENDERS: dict[str, Callable[[Any, Record], None]] = {
    "email": send_email, "push": send_push, "webhook": send_webhook,
}


async def deliver(target: Target, record: Record, gate: asyncio.Semaphore, *, backoff_s: float = 1.0) -> bool:
    for attempt in range(ATTEMPTS):
        try:
            async with gate:
                await asyncio.to_thread(SENDERS[target.channel], target.address, record)
            return True
        except Permanent as exc:
            log.warning("alert not sent by %s: %s", target.channel, exc)
            if target.subscription_id is not None:
                await PushSubscription.objects.filter(id=target.subscription_id).adelete()
            return False
        except Exception as exc:
            if attempt == ATTEMPTS - 1:
                log.error("alert not sent by %s after %d attempts: %s", target.channel, ATTEMPTS, exc)
                return False
            await asyncio.sleep(backoff_s * 2 ** attempt)
    return False


class Outbox(asyncio.Queue[Record]):
    """The alerts waiting for delivery, while ``run_delivery`` runs in this process."""


def offer(record: Record) -> None:
    """Queue a new alert for delivery (called where it was raised; never blocks)."""
    outbox = running(Outbox)
    if outbox is None:
        return
    try:
        outbox.put_nowait(record)
    except asyncio.QueueFull:
        log.error("alert delivery is %d behind: not sending %s", MAX_QUEUED, record.text)


async def run_delivery(link: RobotLink) -> None:
    gate = asyncio.Semaphore(PARALLEL)
    sending = Tasks()
    try:
        with holding(Outbox(maxsize=MAX_QUEUED)) as outbox:
            while True:
                record = await outbox.get()
                try:
                    targets = await sync_to_async(recipients)(record.kind, record.severity)
                except Exception:
                    log.exception("could not find who wants the alert %s", record.text)
                    continue
                for target in targets:
                    sending.start(deliver(target, record, gate))
    finally:
        sending.cancel()


def install() -> None:
    from robot.alerts import engine

    if offer not in engine.raised_hooks:
        engine.raised_hooks.append(offer)
    register_background("alerts-delivery", run_delivery)
