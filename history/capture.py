"""What the black box and the camera recorder share: a ring of the last ``INCIDENT_BEFORE_S``
seconds, the windows of the incidents being captured, and batches written from a worker thread.

Items are queued on the event-loop thread (never blocking) and written by ``flush``; a batch whose
write failed is counted lost, the failure logged once per outage."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from django.conf import settings

from history.storage import FailureLog


class Capture[T]:
    def __init__(self, writer: Callable[[Sequence[Any]], int], what: str) -> None:
        self.writer = writer
        self.keep_s = settings.INCIDENT_BEFORE_S + 5.0
        self.ring: deque[list[Any]] = deque()  # [t, item, kept]: kept once on its way to storage
        self.windows: dict[int, tuple[float, float]] = {}  # incident id -> (start, end)
        self._pending: list[T] = []
        self._write_log = FailureLog(what)
        self.received = self.stored = self.lost = 0

    def _remember(self, t: float, item: Any) -> list[Any]:
        self.received += 1
        entry = [t, item, False]
        self.ring.append(entry)
        while self.ring and self.ring[0][0] < t - self.keep_s:
            self.ring.popleft()
        return entry

    def _incident_at(self, t: float) -> int | None:
        return next((i for i, (start, end) in self.windows.items() if start <= t <= end), None)

    def _unkept(self, start: float, end: float) -> Iterator[list[Any]]:
        """The ring's entries in [start, end] not yet on their way to storage."""
        return (entry for entry in self.ring if not entry[2] and start <= entry[0] <= end)

    def release_past(self, now: float) -> None:
        self.windows = {incident: window for incident, window in self.windows.items() if window[1] >= now}

    def _batch(self, pending: list[T]) -> Sequence[Any]:
        """What the writer is given for the pending items."""
        return pending

    async def flush(self) -> int:
        pending, self._pending = self._pending, []
        if not pending:
            return 0
        written = await self._write_log.attempt(self.writer, self._batch(pending))
        if written is None:
            self.lost += len(pending)
            return 0
        self.stored += written
        return written
