"""Audit entries written from the event loop by one long-lived thread that keeps its connection.

Django's connections belong to a thread, and a thread per request (``ThreadSensitiveContext``)
meant a new database connection for every command's audit row: most of the row's cost. Here the
asynchronous face's audit rows go to one worker thread whose connection stays open between
writes and is closed after ``IDLE_CLOSE_S`` without any, so a quiet server holds none.

A write is never dropped and never fails silently: it runs even when its caller was cancelled,
and a write that meets a kept connection the database has since dropped is retried once on a new
one. While the database is down an entry goes to the journal on disk (``audit_journal``) and the
writer is ``down``: the pipeline refuses every command but the E-STOP and its release until the
thread, probing every ``PROBE_S``, has written the journal to the database. Any other failure is
logged here and raised to the caller.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import queue
import threading
from concurrent.futures import Future, InvalidStateError
from typing import Any

from django.db import InterfaceError, OperationalError, connection

from robot.commands import audit_journal
from robot.commands.audit import audit_record
from robot.models import AuditEntry

log = logging.getLogger(__name__)

IDLE_CLOSE_S = 10.0
PROBE_S = 1.0

_Job = tuple[Future, dict[str, Any] | None]  # no fields: close the connection
_REPLAY: dict[str, Any] = {}  # fields that say: write what the journals hold


def _write(fields: dict[str, Any]) -> AuditEntry:
    kept = connection.connection is not None
    try:
        return audit_record(**fields)
    except (OperationalError, InterfaceError):
        connection.close()
        if not kept:
            raise
        log.warning("audit: the kept database connection was gone; writing on a new one")
    return audit_record(**fields)


class AuditWriter:
    def __init__(self, idle_close_s: float = IDLE_CLOSE_S) -> None:
        self.idle_close_s = idle_close_s
        self._jobs: queue.SimpleQueue[_Job] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._start = threading.Lock()
        self.writes = 0  # jobs handed to the thread: one thread crossing each
        self.down = False  # entries are being journaled: the database did not take the last one

    async def record(self, **fields: Any) -> AuditEntry | None:
        """``audit_record(**fields)`` on the writer's thread (None: journaled, the database is down)."""
        future: Future[AuditEntry] = Future()
        self._ensure_thread()
        self.writes += 1
        self._jobs.put((future, fields))
        return await asyncio.shield(asyncio.wrap_future(future))

    def record_here(self, **fields: Any) -> AuditEntry | None:
        """``audit_record(**fields)`` in the caller's thread (the synchronous face), journaled likewise;
        at once while the writer is ``down`` (its thread writes the journal when the database is back),
        so a refusal does not first wait out a connection attempt (the pool's ``timeout``)."""
        if self.down:
            self._keep(fields)
            self._ensure_thread()
            return None
        try:
            return audit_record(**fields)
        except (OperationalError, InterfaceError):
            self._keep(fields)
            self._ensure_thread()  # it probes the database and writes the journal when it is back
            return None

    def keep_then_write(self, *, wait_s: float, **fields: Any) -> None:
        """Journal the entry (on disk before this returns), then have the writer's thread write it;
        wait for that at most ``wait_s``: the caller never waits longer on the database, however it
        hangs (the E-STOP's own entries)."""
        audit_journal.keep(fields)
        self._ensure_thread()
        written: Future[None] = Future()
        self._jobs.put((written, _REPLAY))
        with contextlib.suppress(TimeoutError):
            written.result(wait_s)

    def _keep(self, fields: dict[str, Any]) -> None:
        audit_journal.keep(fields)
        log.warning("audit: the database is not reachable; %s by %s journaled until it is", fields.get("action"),
                    getattr(fields.get("user"), "username", "?"))
        self.down = True

    def _replay(self) -> None:
        """Write the journals; ``down`` says whether the database took them, logged as it changes."""
        try:
            audit_journal.replay()
        except (OperationalError, InterfaceError):
            connection.close()
            if not self.down:
                self.down = True
                log.warning("audit: the database is not reachable; journaled entries wait until it is")
            return
        if self.down:
            self.down = False
            log.info("audit: the database is back; commands are accepted again")

    def close_connection(self, timeout: float = 10.0) -> None:
        """Close the writer's connection now (e.g. before a test database is dropped)."""
        if self._thread is not None and self._thread.is_alive():
            done: Future[None] = Future()
            self._jobs.put((done, None))
            done.result(timeout)

    def _ensure_thread(self) -> None:
        if self._thread is None or not self._thread.is_alive():
            with self._start:
                if self._thread is None or not self._thread.is_alive():
                    self._thread = threading.Thread(target=self._run, name="audit-writer", daemon=True)
                    self._thread.start()

    def _run(self) -> None:
        while True:
            try:
                future, fields = self._jobs.get(timeout=PROBE_S if self.down else self.idle_close_s)
            except queue.Empty:
                if self.down:
                    self._replay()
                else:
                    connection.close()
                continue
            if fields is None:
                connection.close()
                _settle(future)
                continue
            if fields is _REPLAY:
                self._replay()
                _settle(future)
                continue
            try:
                result = _write(fields)
            except (OperationalError, InterfaceError):
                connection.close()
                try:
                    self._keep(fields)
                except BaseException as exc:
                    log.exception("audit: the entry for %s was neither written nor journaled", fields.get("action"))
                    _settle(future, exception=exc)
                else:
                    _settle(future, result=None)
            except BaseException as exc:
                connection.close()
                log.exception("audit: the entry for %s by %s was not written", fields.get("action"),
                              getattr(fields.get("user"), "username", "?"))
                _settle(future, exception=exc)
            else:
                _settle(future, result=result)


def _settle(future: Future, *, result: Any = None, exception: BaseException | None = None) -> None:
    with contextlib.suppress(InvalidStateError):  # its caller is gone; the write was made (or logged) all the same
        if exception is not None:
            future.set_exception(exception)
        else:
            future.set_result(result)


writer = AuditWriter()
