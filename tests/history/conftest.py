"""History fixtures: a fast recorder, a burst topic, a real Celery worker on Redis."""

from __future__ import annotations

import uuid

import pytest

# Not a registry topic on purpose: the recorder must take any name and any type.
BURST_TOPIC = "/history_test/burst"
BURST_TYPE = "std_msgs/Int32"
CELERY_REDIS = "redis://127.0.0.1:6379/14"


@pytest.fixture
def fast_history(settings):
    settings.HISTORY_FLUSH_S = 0.05
    settings.HISTORY_POLICY_RELOAD_S = 0.05
    return settings


@pytest.fixture
def celery_app():
    """A Celery app on Redis with its own queue, so no other worker takes our tasks."""
    from celery import Celery

    import history.tasks  # noqa: F401  (registers the shared tasks)

    app = Celery(f"history-test-{uuid.uuid4().hex[:8]}", broker=CELERY_REDIS, backend=CELERY_REDIS,
                 set_as_current=False)
    app.conf.update(task_default_queue=f"history-test-{uuid.uuid4().hex}", task_ignore_result=True,
                    broker_connection_retry_on_startup=True, worker_hijack_root_logger=False)
    yield app
    app.close()


@pytest.fixture
def celery_worker_thread(celery_app, transactional_db):
    """A real worker (solo pool, in a thread) consuming the test app's queue from Redis."""
    from celery.contrib.testing.worker import start_worker

    with start_worker(celery_app, pool="solo", perform_ping_check=False, shutdown_timeout=10) as worker:
        yield worker


@pytest.fixture
async def recording(fast_history, link):
    """The link with history's recorder running, as ``start_link`` runs it."""
    import asyncio

    from history.recorder import Recorder, run_recorder
    from robot.supervisor import running

    tasks = [asyncio.ensure_future(run_recorder(link))]
    await asyncio.sleep(0)
    made = running(Recorder)
    assert made is not None
    yield made
    for task in tasks:
        task.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)
