"""The audit writer: one thread and one kept connection for the rows, never a silent loss."""

from __future__ import annotations

import asyncio
import logging
import threading

import pytest
from django.db import OperationalError
from django.db.backends.signals import connection_created

from robot.commands import audit_writer
from robot.commands.audit_writer import AuditWriter
from robot.models import AuditEntry

# The audit writer's own long-lived connection.
pytestmark = [pytest.mark.postgres, pytest.mark.django_db(transaction=True)]


def fields(action: str) -> dict:
    return {"user": None, "source": "api", "action": action, "params": {}, "ok": True, "outcome": "done"}


@pytest.fixture
def writer():
    made = AuditWriter()
    yield made
    made.down = False  # no probe after the test (its journal folder is gone)
    made.close_connection()


@pytest.fixture
def opened():
    """Connections the writer's thread opened."""
    threads: list[str] = []

    def record(sender, connection, **kwargs):
        if threading.current_thread().name == "audit-writer":
            threads.append("audit-writer")

    connection_created.connect(record)
    yield threads
    connection_created.disconnect(record)


async def test_it_writes_every_row_on_one_connection_it_keeps(writer, opened):
    for n in range(3):
        await writer.record(**fields(f"test.kept{n}"))
    assert opened == ["audit-writer"]
    assert await AuditEntry.objects.filter(action__startswith="test.kept").acount() == 3
    writer.close_connection()
    await writer.record(**fields("test.reopened"))
    assert opened == ["audit-writer", "audit-writer"]


async def test_any_other_failure_is_logged_and_raised(writer, monkeypatch, caplog):
    def broken(**kwargs):
        raise ValueError("a bug")

    monkeypatch.setattr(audit_writer, "audit_record", broken)
    with caplog.at_level(logging.ERROR, logger="robot.commands.audit_writer"), pytest.raises(ValueError):
        await writer.record(**fields("test.lost"))
    assert "the entry for test.lost by ? was not written" in caplog.text and not writer.down


async def test_with_the_database_down_an_entry_is_journaled_and_written_when_it_returns(writer, monkeypatch):
    from robot.commands import audit_journal

    def down(**kwargs):
        raise OperationalError("connection to server failed: Connection refused")

    monkeypatch.setattr(audit_writer, "audit_record", down)
    assert await writer.record(**fields("test.journaled")) is None
    assert writer.down and audit_journal.pending() == 1
    assert not await AuditEntry.objects.filter(action="test.journaled").aexists()
    monkeypatch.undo()  # the database answers again: the writer's probe writes the journal
    deadline = asyncio.get_running_loop().time() + 10
    while writer.down and asyncio.get_running_loop().time() < deadline:
        await asyncio.sleep(0.05)
    assert not writer.down and audit_journal.pending() == 0
    entry = await AuditEntry.objects.aget(action="test.journaled")
    assert (entry.ok, entry.outcome, entry.source) == (True, "done", "api")


async def test_a_kept_connection_that_was_dropped_is_replaced_once(writer, monkeypatch, caplog):
    await writer.record(**fields("test.first"))  # the connection is now kept
    real, calls = audit_writer.audit_record, []

    def dropped_once(**kwargs):
        calls.append(kwargs["action"])
        if len(calls) == 1:
            raise OperationalError("server closed the connection unexpectedly")
        return real(**kwargs)

    monkeypatch.setattr(audit_writer, "audit_record", dropped_once)
    with caplog.at_level(logging.WARNING, logger="robot.commands.audit_writer"):
        await writer.record(**fields("test.second"))
    assert calls == ["test.second", "test.second"]
    assert await AuditEntry.objects.filter(action="test.second").acount() == 1
    assert "writing on a new one" in caplog.text


async def test_a_fresh_connection_that_fails_is_not_retried(writer, monkeypatch):
    calls = []

    def refused(**kwargs):
        calls.append(kwargs["action"])
        raise OperationalError("connection refused")

    monkeypatch.setattr(audit_writer, "audit_record", refused)
    assert await writer.record(**fields("test.refused")) is None  # journaled
    assert calls == ["test.refused"]


async def test_a_cancelled_caller_still_gets_its_row_written(writer, monkeypatch):
    real, started, release = audit_writer.audit_record, threading.Event(), threading.Event()

    def slow(**kwargs):
        started.set()
        release.wait(5)
        return real(**kwargs)

    monkeypatch.setattr(audit_writer, "audit_record", slow)
    task = asyncio.ensure_future(writer.record(**fields("test.cancelled")))
    await asyncio.to_thread(started.wait, 5)
    task.cancel()
    release.set()
    with pytest.raises(asyncio.CancelledError):
        await task
    monkeypatch.setattr(audit_writer, "audit_record", real)
    await writer.record(**fields("test.after"))  # queued behind it: the cancelled one is written by now
    assert await AuditEntry.objects.filter(action="test.cancelled").acount() == 1
