"""The recorder: history's one way in, where the link runs.

``offer`` is a link listener: it runs on the event-loop thread for every message and judges
each once: its topic records every message, or it is due (its topic's interval has passed
since the last one kept), or it falls in an open incident's window. What is kept goes into
the one buffer. The camera's frames come in the same way (``offer_frame``): one every
1 / ``CAMERA_RECORD_FPS`` seconds, or every frame inside an incident's window. What is not
kept of the black box's topics and of the camera waits in a ring of the last
``INCIDENT_BEFORE_S`` seconds, so an incident opened a moment later (``hold``) keeps the
seconds before it at full rate.

``run`` (a background service where the link runs) swaps the buffer out every
``HISTORY_FLUSH_S`` (or sooner when a batch is full) and writes it from a worker thread with
the one writer (``storage.write_batch``: samples with their rollups, frames as files). It also
reloads the policies and subscribes the link to the topics they name.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any, TypeGuard

from django.conf import settings

from history.defaults import ensure_default_policies
from history.frames import Frame
from history.incidents import BLACKBOX_KEYS
from history.models import Mode
from history.policies import Policy, load_policies
from history.sessions import SessionNotes
from history.storage import FailureLog, Item, Pending, Taken, encode, newest_samples, write_batch
from robot import interface as ri
from robot.supervisor import holding

log = logging.getLogger(__name__)

Writer = Callable[[Sequence[Item]], int]

# The latest-state store key where the recorder leaves, per every-message topic, the last message it
# wrote (receive time and header.seq) and the topic's rate, with the running count of messages lost
# between recorders: the next recorder (a standby link taking over, a restart) counts the messages that
# fell between the two, exactly from header.seq when the robot numbers them, else from time x rate.
# /healthz reports the count (dashboard.health). A Redis restart empties it.
WATERMARK_KEY = "_recorder"
# The recorder's hold on the link's upstream subscriptions (others may hold the same topics).
LINK_HOLDER = "recorder"
# Where the camera's frames are "due" in the recorder's bookkeeping (not a ROS topic).
CAMERA = "camera"


def is_due(t: float, last: float, interval_s: float) -> bool:
    # Messages arrive with jitter; without a little slack a 5 s topic sampled every 5 s skips periods.
    slack = min(0.25, interval_s * 0.1)
    return t > last and t - last >= interval_s - slack


def header_seq(msg: dict[str, Any]) -> int | None:
    header = msg.get("header")
    seq = header.get("seq") if isinstance(header, dict) else None
    return seq if isinstance(seq, int) and not isinstance(seq, bool) and seq > 0 else None


def messages_between(previous: list[Any], t: float, seq: int | None) -> int | None:
    """Messages published after the previous recorder's last written one ([t, rate, seq]) and
    before this one's first (at ``t``, numbered ``seq``); None when it cannot be told."""
    last_t, rate_hz = float(previous[0]), float(previous[1])
    last_seq = previous[2] if len(previous) > 2 else None
    if seq is not None and isinstance(last_seq, int):
        # A lower number: the publisher restarted (the robot rebooted) and its count with it.
        return seq - last_seq - 1 if seq > last_seq else None
    return max(0, round((t - last_t) * rate_hz) - 1)


def _is_frame(item: Taken) -> TypeGuard[Frame]:
    return len(item) == 3


class Recorder:
    def __init__(
        self,
        *,
        writer: Writer = write_batch,
        flush_s: float | None = None,
        batch_rows: int | None = None,
        buffer_rows: int | None = None,
    ) -> None:
        self.writer = writer
        self.flush_s = flush_s or settings.HISTORY_FLUSH_S
        self.batch_rows = batch_rows or settings.HISTORY_BATCH_ROWS
        self.buffer_rows = buffer_rows or settings.HISTORY_BUFFER_ROWS
        self.policies: dict[str, Policy] = {}
        self.limits: dict[str, int] = {}
        self.every: frozenset[str] = frozenset()
        self.periodic: frozenset[str] = frozenset()
        self.blackbox_topics = frozenset(ri.topic(key).name for key in BLACKBOX_KEYS)
        self._last_due: dict[str, float] = {}
        self.ring: deque[tuple[float, Taken]] = deque()  # what the black box may still want, oldest first
        self.windows: dict[int, tuple[float, float]] = {}  # incident id -> (start, end)
        self._buffer: list[Taken] = []
        self._full: asyncio.Event | None = None
        self._subscribed_by_us: set[str] = set()
        self._defaults_ros = ri.configured_ros() or ri.ROS1  # the ROS bootstrap made the default policies for
        self._reload_log = FailureLog("loading recording policies")
        self._write_log = FailureLog("writing recorded messages")
        self._retry: list[Item] = []
        self.received = self.stored = self.dropped = self.oversize = 0
        # Every-message topics: [first t, last t, messages] taken here; (t, seq) of the last one written;
        # the previous recorder's [last t, rate, last seq].
        self._seen: dict[str, list[float]] = {}
        self._written: dict[str, tuple[float, int | None]] = {}
        self._previous: dict[str, list[Any]] = {}
        self.gap_lost: dict[str, int] = {}  # messages lost between the previous recorder and this one
        self.lost_total: dict[str, int] = {}  # the same, summed over every recorder since Redis started
        self.sessions = SessionNotes()

    # --- on the event-loop thread: never blocks --------------------------------------

    def offer(self, name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        if name in self.every:
            self.received += 1
            seen = self._seen.get(name)
            if seen is None:
                self._seen[name] = [t, t, 1]
                self._count_gap(name, t, header_seq(msg))
            else:
                seen[1], seen[2] = t, seen[2] + 1
            self._keep((name, msg_type, msg, t))
        elif name in self.periodic:
            self.received += 1
            # The topics recorded every N seconds are those an incident keeps every message of.
            self._judge(name, (name, msg_type, msg, t), t, self.policies[name].interval_s,
                        name in self.blackbox_topics)

    def offer_frame(self, t: float, jpeg: bytes) -> None:
        """A camera frame (receive time on the server's clock, like every recorded message)."""
        fps = settings.CAMERA_RECORD_FPS
        self._judge(CAMERA, (t, jpeg, None), t, 1.0 / fps * 0.95 if fps > 0 else None, True)

    def _judge(self, name: str, item: Taken, t: float, interval_s: float | None, ringed: bool) -> None:
        if ringed and (incident := self._incident_at(t)) is not None:
            self._keep(_for_incident(item, incident))
        elif interval_s is not None and is_due(t, self._last_due.get(name, 0.0), interval_s):
            self._last_due[name] = t
            self._keep(item)
        elif ringed:
            self.ring.append((t, item))
            horizon = t - settings.INCIDENT_BEFORE_S - 5.0
            while self.ring and self.ring[0][0] < horizon:
                self.ring.popleft()

    def _keep(self, item: Taken) -> None:
        if len(self._buffer) >= self.buffer_rows:
            self.dropped += 1
            if self.dropped == 1 or self.dropped % 1000 == 0:
                log.error("history: buffer full (%d rows); dropped %d so far (last on %s)",
                          self.buffer_rows, self.dropped, CAMERA if _is_frame(item) else item[0])
            return
        self._buffer.append(item)
        if len(self._buffer) >= self.batch_rows and self._full is not None:
            self._full.set()

    def _incident_at(self, t: float) -> int | None:
        return next((i for i, (start, end) in self.windows.items() if start <= t <= end), None)

    def hold(self, incident: int, start: float, end: float) -> None:
        """Keep everything in [start, end] for ``incident``: what the ring holds now and what comes."""
        self.windows[incident] = (start, end)
        ring, self.ring = self.ring, deque()
        for t, item in ring:
            if start <= t <= end:
                self._keep(_for_incident(item, incident))
            else:
                self.ring.append((t, item))

    def release_past(self, now: float) -> None:
        self.windows = {incident: window for incident, window in self.windows.items() if window[1] >= now}

    def _count_gap(self, name: str, t: float, seq: int | None) -> None:
        previous = self._previous.pop(name, None)
        if previous is None:
            return
        lost = messages_between(previous, t, seq)
        if lost is None:
            log.warning("history: %s restarted its numbering since the previous recorder's last message; "
                        "the messages between them are not counted", name)
            return
        self.gap_lost[name] = self.gap_lost.get(name, 0) + lost
        self.lost_total[name] = self.lost_total.get(name, 0) + lost
        if lost:
            log.warning("history: %d messages of %s were not recorded in the %.2f s between the previous "
                        "recorder's last one and this one's first (a link failover or restart); %d so far",
                        lost, name, t - float(previous[0]), self.lost_total[name])

    async def resume_after(self, store: Any) -> None:
        """Pick up where the previous recorder (another link, an earlier run) left off, to count the gap."""
        previous = (await store.aget_many([WATERMARK_KEY])).get(WATERMARK_KEY) or {}
        self._previous = dict(previous.get("topics", {}))
        self.lost_total = {name: int(n) for name, n in previous.get("lost", {}).items()}

    def watermark(self) -> dict[str, Any]:
        topics: dict[str, list[Any]] = {}
        for name, (last_t, seq) in self._written.items():
            first, last, n = self._seen.get(name, (last_t, last_t, 1))
            topics[name] = [last_t, (n - 1) / (last - first) if last > first else 0.0, seq]
        # A topic this recorder has not written yet keeps the previous recorder's mark.
        return {"topics": {**self._previous, **topics}, "lost": dict(self.lost_total)}

    def apply(self, policies: dict[str, Policy]) -> None:
        self.policies = policies
        self.limits = {p.topic: p.max_bytes for p in policies.values()}
        self.every = frozenset(p.topic for p in policies.values() if p.mode == Mode.EVERY)
        self.periodic = frozenset(p.topic for p in policies.values() if p.mode == Mode.PERIODIC)
        for name in set(self._last_due) - self.periodic - {CAMERA}:
            self._last_due.pop(name, None)

    # --- flushing ---------------------------------------------------------------------

    def take(self) -> list[Taken]:
        pending, self._buffer = self._buffer, []
        return pending

    def flush_sync(self, pending: Sequence[Taken]) -> int:
        frames: list[Item] = []
        messages: list[Pending] = []
        for item in pending:
            if len(item) == 3:  # a frame
                frames.append(item)
            else:
                messages.append(item)
        rows, oversize = encode(messages, self.limits, default_max=settings.HISTORY_MAX_MESSAGE_BYTES)
        self.oversize += oversize
        batch: list[Item] = [*self._retry, *rows, *frames]
        self._retry = []
        for start in range(0, len(batch), self.batch_rows):
            try:
                self.stored += self.writer(batch[start:start + self.batch_rows])
            except Exception:
                # Keep what was not written for the next flush, within the same memory bound.
                self._retry = batch[start:start + self.buffer_rows]
                self.dropped += len(batch) - start - len(self._retry)
                raise
        marks = {name: (t, header_seq(msg)) for name, _, msg, t in messages}  # the last of each topic wins
        self._written = {**self._written, **marks}  # rebound, never mutated: the loop thread reads it
        return len(batch)

    async def flush(self) -> int:
        pending = self.take()
        if not pending and not self._retry:
            return 0
        return await self._write_log.attempt(self.flush_sync, pending) or 0

    async def run(self, link: Any) -> None:
        """Background service: reload policies, keep subscriptions, flush batches, leave the watermark."""
        self._full = asyncio.Event()
        await self.resume_after(link.store)
        if self.offer not in link.listeners:
            link.listeners.append(self.offer)
        next_reload = 0.0
        try:
            while True:
                if time.monotonic() >= next_reload:
                    await self.reload(link)
                    next_reload = time.monotonic() + settings.HISTORY_POLICY_RELOAD_S
                try:
                    await asyncio.wait_for(self._full.wait(), self.flush_s)
                except TimeoutError:
                    pass
                self._full.clear()
                if hasattr(link, "connected"):
                    self._buffer.extend(self.sessions.note(connected=link.connected, since=link.dial.since,
                                                           now=time.time()))
                await self.flush()
                await self.publish_watermark(link.store)
        finally:
            if self.offer in link.listeners:
                link.listeners.remove(self.offer)
            await self.flush()  # a clean stop (SIGTERM, lease handed over) loses nothing it took
            try:
                await self.publish_watermark(link.store)
            except Exception:
                log.warning("history: could not leave the recorder's watermark on stopping", exc_info=True)

    async def reload(self, link: Any) -> None:
        ros = ri.ros_version()
        if ros != self._defaults_ros and await self._reload_log.attempt(ensure_default_policies) is not None:
            # The link found the robot runs another ROS than bootstrap assumed: its names and types.
            self._defaults_ros = ros
            self.blackbox_topics = frozenset(ri.topic(key).name for key in BLACKBOX_KEYS)
        policies = await self._reload_log.attempt(load_policies)
        if policies is None:
            return  # the previous policies stay in force
        new = [p.topic for p in policies.values() if p.mode == Mode.PERIODIC and p.topic not in self._last_due]
        if new:
            # A recorder taking over (a failover, a restart) goes on from the last sample stored, not twice.
            last = await self._reload_log.attempt(newest_samples, new)
            if last is None:
                return
            self._last_due.update(last)
        self.apply(policies)
        wanted = {p.topic: p.msg_type for p in policies.values() if p.mode != Mode.OFF and p.msg_type}
        for name, msg_type in wanted.items():
            link.subscriptions.subscribe(name, msg_type, holder=LINK_HOLDER)
            self._subscribed_by_us.add(name)
        for name in self._subscribed_by_us - set(wanted):
            link.subscriptions.unsubscribe(name, holder=LINK_HOLDER)
            self._subscribed_by_us.discard(name)

    async def publish_watermark(self, store: Any) -> None:
        if self._written or self.lost_total:
            await store.aput(WATERMARK_KEY, self.watermark())


def _for_incident(item: Taken, incident: int) -> Taken:
    """A frame kept for an incident carries its id; a message is kept as it is."""
    return (item[0], item[1], incident) if _is_frame(item) else item


def losses(watermark: dict[str, Any] | None) -> dict[str, int]:
    """Per every-message topic, the messages lost between recorders so far (for /healthz)."""
    return {name: int(n) for name, n in ((watermark or {}).get("lost") or {}).items()}


async def run_recorder(link: Any) -> None:
    """The background service registered in ``HistoryConfig.ready``."""
    with holding(Recorder()) as made:
        await made.run(link)
