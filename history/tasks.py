"""Celery tasks (thin): the beat schedule in settings runs ``history.sample`` and ``history.prune``."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from celery import Celery, shared_task

from history.retention import prune_expired
from history.sampling import sample_periodic
from history.storage import Row, write_rows


@shared_task(name="history.sample", ignore_result=True)
def sample() -> int:
    return sample_periodic()


@shared_task(name="history.prune", ignore_result=True)
def prune() -> int:
    return prune_expired()


@shared_task(name="history.write_batch", ignore_result=True)
def write_batch(rows: list[list]) -> int:
    """Rows handed over by a recorder that writes through the worker (``HISTORY_BATCH_WRITER=celery``)."""
    return write_rows([(str(topic), str(msg_type), float(t), str(text)) for topic, msg_type, t, text in rows])


def celery_writer_for(app: Celery | None = None) -> Callable[[Sequence[Row]], int]:
    """A recorder writer that queues each batch for a worker instead of writing it here."""

    def write(rows: Sequence[Row]) -> int:
        # The JSON text only (not the parsed message the recorder passes along): the worker parses it.
        (app or write_batch.app).send_task(write_batch.name, args=[[list(r[:4]) for r in rows]])
        return len(rows)

    return write
