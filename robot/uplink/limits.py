"""Refused attempts per address (the token bucket is ``cyborg_site.bucket``)."""

from __future__ import annotations

import time


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
