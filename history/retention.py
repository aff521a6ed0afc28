"""Retention: delete samples older than each topic's maximum age (and their rollups), and old camera frames.

What lies inside an incident's window is kept until an admin releases the incident."""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Any

from django.conf import settings
from django.db import transaction

from history.frames import held_windows, outside, prune_frames
from history.models import Sample, TopicPolicy
from history.storage import FailureLog, in_thread, samples_deleted, utc

log = logging.getLogger(__name__)


def prune_expired(*, now: float | None = None) -> int:
    """Delete every topic's samples older than its retention; returns rows deleted."""
    now = now or time.time()
    deleted = 0
    held = [(utc(start), utc(end)) for start, end in held_windows()]
    for topic, retention_s in TopicPolicy.objects.filter(retention_s__isnull=False).values_list("topic", "retention_s"):
        if retention_s is None:  # excluded by the filter; the column is nullable
            continue
        cutoff = now - retention_s
        with transaction.atomic():
            count, _ = Sample.objects.filter(topic=topic, received_at__lt=utc(cutoff)).filter(
                outside(held, "received_at")).delete()
            if count:
                samples_deleted(topic=topic, start=None, end=cutoff)
                log.info("history: pruned %d samples of %s older than %g s", count, topic, retention_s)
        deleted += count
    return deleted + prune_frames(now=now)


async def run_pruning(link: Any) -> None:
    """Embedded default: the beat schedule's pruning inside the server process."""
    failures = FailureLog("pruning expired history")
    while True:
        try:
            await in_thread(prune_expired)
            failures.ok()
        except Exception:
            failures.failed()
        await asyncio.sleep(settings.HISTORY_PRUNE_EVERY_S)
