"""The drive lock: one driver at a time, across every web process (a held lock, robot.live.locks).

The holder is one websocket connection (its channel name), shown by username. The lock expires
``TELEOP_LOCK_TTL_S`` after its last refresh (every published Twist refreshes it), so a driver who
walks away, or a web process that dies, frees it.
"""

from __future__ import annotations

from django.conf import settings

from robot.live.locks import HeldLock, held_lock

_lock: HeldLock | None = None


def get_lock() -> HeldLock:
    global _lock
    if _lock is None:
        _lock = held_lock("teleop-lock", settings.TELEOP_LOCK_TTL_S)
    return _lock


def reset_lock() -> None:
    """Forget the configured lock (tests that change settings)."""
    global _lock
    _lock = None
