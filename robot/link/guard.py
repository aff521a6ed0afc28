"""The last word on ``cmd_vel``, kept by the process that publishes it (the robot link).

- Deadman: a moving Twist must be followed by another within ``deadman_s``; when the stream
  goes quiet (a web process died, a driver's loop stalled) the guard publishes zero itself.
- E-STOP: once engaged it publishes zero at once and again at the teleop rate for a short
  hold, and refuses every non-zero Twist until released, and every other publish or service
  call that would move the robot or change its mode or motors (``interface.passes_latch``): the
  last check before the robot, so no sequence, queued request or stale process outlives a stop.
- Lost link: after the connection to the robot drops (a blip, the uplink redialling, the robot
  restarting), a moving Twist goes out only after a zero or as a fresh press (a driver's first move
  after letting go): a key held through the loss must be let go and pressed again, so a restored link
  never restarts motion by itself.
- Stop: a link that shuts down while the robot moves sends zero first.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from typing import Any

from robot import interface as ri
from robot.supervisor import Tasks

log = logging.getLogger(__name__)

LATCHED = "E-STOP engaged: refused until an operator releases it"
RELEASE_FIRST = "The link to the robot was lost: let go of the controls and press again to drive"


class CmdVelGuard:
    def __init__(
        self,
        publish_zero: Callable[[], None],
        *,
        loop: asyncio.AbstractEventLoop,
        rate_hz: float,
        hold_s: float,
        deadman_s: float,
    ) -> None:
        self._publish_zero = publish_zero
        self._loop = loop
        self.period = 1.0 / rate_hz
        self.hold_s = hold_s
        self.deadman_s = deadman_s
        self.latched = False
        self.changed_at = 0.0  # monotonic time this link last engaged or released itself
        self.moving = False  # the last Twist that went out was non-zero
        # The connection dropped since the last zero: motion waits for one (or a fresh press). A new
        # link starts so: it may be taking over from one that was lost (a failover, a restart).
        self.release_first = True
        self._deadman: asyncio.TimerHandle | None = None
        self._hold: asyncio.Task | None = None
        self._tasks = Tasks()

    def check_publish(self, name: str, msg: dict[str, Any], *, by_the_stop: bool = False,
                      fresh_press: bool = False) -> str | None:
        """Before anything goes out on topic ``name`` (or to service ``name``): a refusal message, or None."""
        if name == ri.topic("cmd_vel").name:
            return self.check(msg, fresh_press=fresh_press)
        if self.latched and not ri.passes_latch(name, msg, by_the_stop=by_the_stop):
            return f"{LATCHED} ({name})"
        return None

    def check(self, msg: dict[str, Any], *, fresh_press: bool = False) -> str | None:
        """Before a Twist goes out: a refusal message, or None (and the deadman is re-armed)."""
        zero = ri.is_zero_twist(msg)
        if self.latched and not zero:
            return f"{LATCHED} (motion)"
        if self.release_first and not zero and not fresh_press:
            return RELEASE_FIRST
        self.release_first = False
        self.moving = not zero
        self._disarm()
        if self.moving:
            self._deadman = self._loop.call_later(self.deadman_s, self._quiet)
        return None

    def engage(self) -> None:
        """Zero now, zero at the teleop rate for the hold, refuse motion from here on."""
        self.latched = True
        self.changed_at = time.monotonic()
        self._zero()
        if self._hold is None or self._hold.done():
            self._hold = self._tasks.start(self._hold_zero(), loop=self._loop)

    def release(self) -> None:
        self.latched = False
        self.changed_at = time.monotonic()

    def lost(self) -> None:
        """The connection to the robot dropped: what was moving stopped there, and moves wait for a zero."""
        self.release_first = True
        self.moving = False
        self._disarm()

    def settled(self, grace_s: float) -> bool:
        """No engage or release of this link's own for ``grace_s``: the shared store has had time
        to record it, so where the two differ the store is the one to follow (or to repair)."""
        return time.monotonic() - self.changed_at >= grace_s

    def sync(self, latched: bool) -> None:
        """The shared store's view (a press or release made while this link was unreachable)."""
        if latched and not self.latched:
            log.warning("E-STOP latched in the shared store: engaging here too")
            self.engage()
        elif not latched and self.latched:
            log.info("E-STOP released in the shared store")
            self.release()

    def stop(self) -> None:
        """The link is shutting down: zero if the robot may be moving, and no timers left."""
        if self.moving:
            self._zero()
        self._disarm()
        if self._hold is not None:
            self._hold.cancel()

    def _zero(self) -> None:
        self._disarm()
        self.moving = False
        try:
            self._publish_zero()
        except Exception as exc:
            log.warning("could not publish a zero Twist: %s", exc)

    def _disarm(self) -> None:
        if self._deadman is not None:
            self._deadman.cancel()
            self._deadman = None

    def _quiet(self) -> None:
        self._deadman = None
        log.warning("cmd_vel went quiet for %.2f s while moving: publishing zero", self.deadman_s)
        self._zero()

    async def _hold_zero(self) -> None:
        end = self._loop.time() + self.hold_s
        while self._loop.time() < end:
            await asyncio.sleep(self.period)
            self._zero()
