"""The supervisor: a failing task is logged with its traceback and restarted with a growing
backoff, its state feeds health, cancellation stops it, a transient task leaves health."""

import asyncio
import gc
import itertools
import logging

from robot import supervisor
from tests.helpers import DEADLINE_S


async def test_it_logs_and_restarts_a_failing_task_and_reports_it(caplog):
    runs = []
    recovered = asyncio.Event()

    async def flaky() -> None:
        runs.append(asyncio.get_running_loop().time())
        if len(runs) <= 3:
            raise ConnectionError(f"redis gone {len(runs)}")
        recovered.set()
        await asyncio.sleep(3600)

    with caplog.at_level(logging.ERROR, logger="robot.supervisor"):
        task = supervisor.supervise("test.flaky", flaky)
        await asyncio.wait_for(recovered.wait(), 5)
    state = supervisor.health()["test.flaky"]
    assert state["state"] == "running" and state["restarts"] == 3
    assert state["last_error"] == "ConnectionError: redis gone 3"
    gaps = [b - a for a, b in itertools.pairwise(runs)]
    # The backoff doubles: each wait is at least twice the first (sleeps only ever run long).
    assert gaps[0] >= supervisor.INITIAL_BACKOFF_S * 0.95 and gaps[1] >= 2 * supervisor.INITIAL_BACKOFF_S * 0.95
    assert gaps[2] >= 4 * supervisor.INITIAL_BACKOFF_S * 0.95
    failures = [r for r in caplog.records if "test.flaky failed" in r.getMessage()]
    assert len(failures) == 3 and all(r.exc_info for r in failures)  # with the traceback
    task.cancel()
    await asyncio.gather(task, return_exceptions=True)
    assert supervisor.health()["test.flaky"]["state"] == "finished"
    supervisor.forget("test.flaky")


async def test_it_reports_a_task_waiting_to_restart():
    async def broken() -> None:
        raise RuntimeError("always")

    task = supervisor.supervise("test.broken", broken, max_backoff_s=5)
    await asyncio.sleep(0.05)
    assert "test.broken" in supervisor.failing()
    task.cancel()
    await asyncio.gather(task, return_exceptions=True)
    supervisor.forget("test.broken")


async def test_a_transient_task_leaves_health_when_it_ends():
    async def once() -> None:
        await asyncio.sleep(0)

    await supervisor.supervise("test.once", once, transient=True)
    assert "test.once" not in supervisor.health()


async def test_a_cancelled_task_whose_clean_up_fails_stops_all_the_same():
    started = asyncio.Event()

    async def reads_from_redis():
        started.set()
        try:
            await asyncio.sleep(3600)
        finally:  # a clean-up that fails on the way out, Redis being down: its error replaces the cancel
            raise ConnectionError("Error connecting to 127.0.0.1:6379")

    task = supervisor.supervise("test.failed-clean-up", reads_from_redis)
    await started.wait()
    task.cancel()
    done, _ = await asyncio.wait({task}, timeout=DEADLINE_S)
    assert task in done and task.cancelled()
    assert supervisor.health()["test.failed-clean-up"]["state"] == "finished"


async def test_cancel_and_wait_waits_no_longer_than_told_and_names_what_still_runs(caplog):
    async def write_then_end() -> None:  # as history.storage.in_thread: its database write ends first
        try:
            await asyncio.sleep(3600)
        except asyncio.CancelledError:
            await asyncio.sleep(0.5)
            raise

    quick = asyncio.ensure_future(asyncio.sleep(3600))
    slow = supervisor.supervise("test.slow-to-end", write_then_end)
    await asyncio.sleep(0)
    with caplog.at_level(logging.WARNING, logger="robot.supervisor"):
        await supervisor.cancel_and_wait([quick, slow], 0.1)
    assert quick.cancelled() and not slow.done(), "it waited for the slow one"
    assert "1 task(s) still running 0.1 s after being cancelled" in caplog.text and "test.slow-to-end" in caplog.text
    await asyncio.wait({slow}, timeout=DEADLINE_S)
    assert slow.cancelled()
    supervisor.forget("test.slow-to-end")


async def test_a_task_that_waits_on_what_nobody_holds_is_not_collected_mid_run():
    ended = asyncio.Event()

    async def idle() -> None:
        try:
            await asyncio.get_running_loop().create_future()  # held by nothing but this frame
        finally:
            ended.set()

    supervisor.supervise("test.idle", idle)  # the caller lets go of the task at once
    await asyncio.sleep(0)
    gc.collect()
    await asyncio.sleep(0.05)
    assert not ended.is_set()
    assert supervisor.health()["test.idle"]["state"] == "running"
    for task in asyncio.all_tasks():
        if task.get_name() == "test.idle":
            task.cancel()
    await asyncio.wait_for(ended.wait(), 1)


async def test_an_owners_task_that_fails_unawaited_is_logged_and_one_awaited_is_left_to_its_caller(caplog):
    tasks = supervisor.Tasks()

    async def fail(text: str) -> None:
        raise ValueError(text)

    with caplog.at_level(logging.ERROR, logger="robot.supervisor"):
        unawaited = tasks.start(fail("nobody waits"))
        awaited = tasks.start(fail("the caller waits"), awaited=True)
        await asyncio.wait({unawaited, awaited})
    assert str(awaited.exception()) == "the caller waits"
    logged = [r.exc_info[1] for r in caplog.records if r.exc_info]
    assert [str(exc) for exc in logged] == ["nobody waits"]
    assert len(tasks) == 0  # let go once ended


async def test_closing_an_owner_cancels_and_waits_for_its_tasks():
    tasks = supervisor.Tasks()
    ended = []

    async def forever() -> None:
        try:
            await asyncio.sleep(3600)
        finally:
            ended.append(True)

    for _ in range(3):
        tasks.start(forever())
    await asyncio.sleep(0)
    await tasks.close(1)
    assert ended == [True, True, True] and len(tasks) == 0


def test_a_held_part_is_found_by_its_class_until_released():
    class Part:
        pass

    class Other:
        pass

    first, second = Part(), Part()
    assert supervisor.running(Part) is None
    with supervisor.holding(first):
        supervisor.hold(second)
        assert supervisor.running(Part) is second  # the newest
        assert supervisor.running(Other) is None
        supervisor.release(second)
        assert supervisor.running(Part) is first
    assert supervisor.running(Part) is None
