"""The one token bucket: the live hub's frame pace, the link's per-topic UI rate, the uplink's
message rate and the web process's read throttle."""

from __future__ import annotations

import time


class Bucket:
    """``rate`` tokens a second, at most ``burst`` kept. A token taken before it is there is owed
    (the count goes below zero), so a caller that keeps taking is held to the rate."""

    __slots__ = ("at", "burst", "rate", "tokens")

    def __init__(self, rate: float, burst: float, now: float | None = None) -> None:
        self.rate = rate
        self.burst = burst
        self.tokens = burst
        self.at = time.monotonic() if now is None else now

    def level(self, now: float | None = None) -> float:
        """The tokens in hand, refilled for the time since they were last counted."""
        now = time.monotonic() if now is None else now
        self.tokens = min(self.burst, self.tokens + (now - self.at) * self.rate)
        self.at = now
        return self.tokens

    def wait(self, now: float | None = None) -> float:
        """Seconds until a whole token is in hand (0 when one is)."""
        return max(0.0, (1.0 - self.level(now)) / self.rate)

    def take(self, now: float | None = None) -> float:
        """Take a token; the seconds until it is really there (0 when there was one)."""
        self.level(now)
        self.tokens -= 1.0
        return 0.0 if self.tokens >= 0 else -self.tokens / self.rate
