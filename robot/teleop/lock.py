"""The drive lock: one driver at a time, across every web process (a held lock, robot.live.locks).

The holder is one websocket connection (its channel name), shown by username. The lock expires
``TELEOP_LOCK_TTL_S`` after its last refresh (every published Twist refreshes it), so a driver who
walks away, or a web process that dies, frees it.
"""

from __future__ import annotations

from functools import cache

from django.conf import settings

from robot.live.locks import HeldLock, held_lock


@cache
def get_lock() -> HeldLock:
    return held_lock("teleop-lock", settings.TELEOP_LOCK_TTL_S)


reset_lock = get_lock.cache_clear  # forget the configured lock (tests that change settings)
