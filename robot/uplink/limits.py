"""Limits that are not a library's own: a token bucket (the uplink endpoint's message rate, the web
process's read throttle, ``server.read_throttle``) and refused attempts per address."""

from __future__ import annotations

import time


class Bucket:
    """A token bucket: ``rate`` tokens a second, at most ``burst`` kept."""

    __slots__ = ("at", "tokens")

    def __init__(self, burst: float, now: float) -> None:
        self.tokens = burst
        self.at = now

    def wait_for_token(self, rate: float, burst: float, now: float) -> float:
        """Take a token; the seconds until it is really there (0 when there was one)."""
        self.tokens = min(burst, self.tokens + (now - self.at) * rate)
        self.at = now
        self.tokens -= 1
        return 0.0 if self.tokens >= 0 else -self.tokens / rate


class Attempts:
    """Refused attempts per address: past ``limit`` within ``window_s``, the address is refused
    without a look at what it sends until the window has passed."""

    def __init__(self, limit: int, window_s: float = 60.0) -> None:
        self.limit = limit
        self.window_s = window_s
        self._seen: dict[str, list[float]] = {}

    def _recent(self, address: str) -> list[float]:
        cutoff = time.monotonic() - self.window_s
        recent = [t for t in self._seen.get(address, ()) if t > cutoff]
        if recent:
            self._seen[address] = recent
        else:
            self._seen.pop(address, None)
        return recent

    def blocked(self, address: str) -> bool:
        return len(self._recent(address)) >= self.limit

    def refused(self, address: str) -> bool:
        """Note a refusal; True when this one blocks the address (write that down once)."""
        recent = self._recent(address)
        recent.append(time.monotonic())
        self._seen[address] = recent[-self.limit:]
        if len(self._seen) > 10000:  # a flood from many addresses: forget the oldest
            self._seen.pop(next(iter(self._seen)))
        return len(recent) == self.limit
