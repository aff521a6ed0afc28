"""Periodic topics: store the latest message every N seconds, from the latest-state store.

One function for both wirings: the Celery beat task (``history.sample``) and, in the
embedded default, a loop inside the server process. Safe when several run at once: a
compare-and-set on the policy row lets exactly one of them store each message.

The recorder also keeps a backlog of one message per interval (``HISTORY_BACKLOG_SAMPLES``
per topic) beside the latest one, so a sampler that was stopped (a Celery worker outage)
stores every period it missed when it runs again; only an outage longer than the backlog
loses samples, the oldest first.
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Any

from django.conf import settings
from django.db import transaction

from history.models import Mode, TopicPolicy
from history.policies import load_policies
from history.retention import prune_expired
from history.storage import FailureLog, Pending, encode, in_thread, write_rows
from robot.live.state import get_store

log = logging.getLogger(__name__)

KEY_PREFIX = "history:"


def latest_key(topic: str) -> str:
    """The latest-state store key the recorder keeps a periodic topic's newest message under."""
    return f"{KEY_PREFIX}{topic}"


def is_due(t: float, last: float, interval_s: float) -> bool:
    # Messages arrive with jitter; without a little slack a 5 s topic sampled every 5 s skips periods.
    slack = min(0.25, interval_s * 0.1)
    return t > last and t - last >= interval_s - slack


def sample_periodic(*, store: Any = None) -> int:
    """Store the newest message of each periodic topic whose interval has passed; returns rows stored."""
    store = store or get_store()
    periodic = [p for p in load_policies().values() if p.mode == Mode.PERIODIC]
    if not periodic:
        return 0
    entries = {
        entry.get("topic"): entry for key, entry in store.get_all().items() if key.startswith(KEY_PREFIX)
    }
    due: list[Pending] = []
    with transaction.atomic():
        for policy in periodic:
            latest = entries.get(policy.topic)
            if latest is None:
                continue
            candidates = [*store.get_recent(latest_key(policy.topic)), latest]
            picked, last = [], policy.last_sampled_t
            for entry in sorted(candidates, key=lambda e: float(e["t"])):
                if is_due(float(entry["t"]), last, policy.interval_s):
                    picked.append(entry)
                    last = float(entry["t"])
            if not picked:
                continue
            won = TopicPolicy.objects.filter(topic=policy.topic, last_sampled_t=policy.last_sampled_t).update(
                last_sampled_t=last
            )
            if not won:
                continue  # another sampler stored them
            due.extend((policy.topic, e.get("msg_type") or policy.msg_type, e["msg"], float(e["t"])) for e in picked)
        limits = {p.topic: p.max_bytes for p in periodic}
        rows, _ = encode(due, limits, default_max=settings.HISTORY_MAX_MESSAGE_BYTES)
        return write_rows(rows)


async def run_schedule(link: Any) -> None:
    """Embedded default: the beat schedule (sampling, retention) inside the server process."""
    next_prune = time.monotonic() + settings.HISTORY_SAMPLE_TICK_S
    failures = FailureLog("periodic sampling and pruning")
    while True:
        started = time.monotonic()
        try:
            await in_thread(sample_periodic, store=link.store)
            if started >= next_prune:
                next_prune = started + settings.HISTORY_PRUNE_EVERY_S
                await in_thread(prune_expired)
            failures.ok()
        except Exception:
            failures.failed()
        await asyncio.sleep(max(0.05, settings.HISTORY_SAMPLE_TICK_S - (time.monotonic() - started)))
