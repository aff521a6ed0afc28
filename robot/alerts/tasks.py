"""Celery tasks (thin): the beat schedule in settings runs ``alerts.check_links``."""

from __future__ import annotations

from celery import shared_task

from robot.alerts.watchdog import check_links as _check_links


@shared_task(name="alerts.check_links", ignore_result=True)
def check_links() -> str | None:
    return _check_links()
