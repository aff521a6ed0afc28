"""Celery tasks (thin): the beat schedule in settings runs ``history.prune``."""

from __future__ import annotations

from celery import shared_task

from history.retention import prune_expired


@shared_task(name="history.prune", ignore_result=True)
def prune() -> int:
    return prune_expired()
