"""Retention: delete samples older than each topic's maximum age."""

from __future__ import annotations

import logging
import time

from history.models import Sample, TopicPolicy
from history.storage import forget_buckets, utc

log = logging.getLogger(__name__)


def prune_expired(*, now: float | None = None) -> int:
    """Delete every topic's samples older than its retention; returns rows deleted."""
    now = now or time.time()
    deleted = 0
    for topic, retention_s in TopicPolicy.objects.filter(retention_s__isnull=False).values_list("topic", "retention_s"):
        cutoff = now - retention_s
        count, _ = Sample.objects.filter(topic=topic, received_at__lt=utc(cutoff)).delete()
        if count:
            forget_buckets(topic=topic, end_ms=cutoff * 1000)
            log.info("history: pruned %d samples of %s older than %g s", count, topic, retention_s)
        deleted += count
    return deleted
