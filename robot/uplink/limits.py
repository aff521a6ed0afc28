"""The uplink endpoint's limits that are not the websocket library's own (frame size, handshake time)."""

from __future__ import annotations

import time


class Rate:
    """At most ``per_s`` messages a second, with a second's worth of burst (a token bucket)."""

    def __init__(self, per_s: float) -> None:
        self.per_s = per_s
        self.tokens = per_s
        self.at = time.monotonic()

    def allow(self) -> bool:
        now = time.monotonic()
        self.tokens = min(self.per_s, self.tokens + (now - self.at) * self.per_s)
        self.at = now
        if self.tokens < 1:
            return False
        self.tokens -= 1
        return True


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
