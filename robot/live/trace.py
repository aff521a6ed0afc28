"""Stage timestamps of one key's updates along the live path: a debugging aid, off unless ``LIVE_TRACE_FILE`` is set.

Every update of ``KEY`` is followed from the link's receive to the hub's last socket write, and
written as one JSON line of wall-clock times: ``stamp`` (the robot's header stamp), ``read`` (its
websocket frame began to arrive), ``recv`` (rosbridge callback), ``loop`` (the link's handler on
the event loop), ``drain`` (out of the link's coalescer), ``hub`` (offered to the sockets),
``flush`` and ``written`` (the hub's write of every socket began and ended), and ``sockets``
written. bench/live_fanout.py reads the file to say where a probe's latency goes.
"""

from __future__ import annotations

import json
import time
from typing import Any

from django.conf import settings

KEY = "odom"
enabled = bool(settings.LIVE_TRACE_FILE)
_open: dict[float, dict[str, Any]] = {}
_out: Any = None
read_at = 0.0  # when the link's latest rosbridge frame began to arrive (robot.link.rosclient)


def begin(key: str, t: float, msg: dict[str, Any]) -> None:
    if key != KEY:
        return
    stamp = (msg.get("header") or {}).get("stamp") or {}
    _open[t] = {"stamp": stamp.get("secs", 0) + stamp.get("nsecs", 0) / 1e9, "read": read_at, "recv": t,
               "loop": time.time()}
    if len(_open) > 1000:  # updates that never reached a socket
        del _open[next(iter(_open))]


def mark(t: float, stage: str) -> None:
    record = _open.get(t)
    if record is not None and stage not in record:
        record[stage] = time.time()


def finish(t: float, sockets: int) -> None:
    global _out
    record = _open.pop(t, None)
    if record is None:
        return
    record["written"] = time.time()
    record["sockets"] = sockets
    if _out is None:
        _out = open(settings.LIVE_TRACE_FILE, "a", buffering=1)
    _out.write(json.dumps(record) + "\n")
