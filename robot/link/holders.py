"""Who holds what at the link, each until their lease runs out: one protocol for every holder
that lives in another process (the topics a web process's pages watch, a page listening to the
microphone). A holder renews every ``RENEW_S``; one not renewed for ``LEASE_S`` is gone (its web
process died), and so is what only it held."""

from __future__ import annotations

import time
from collections.abc import Iterable

RENEW_S = 2.0
LEASE_S = 6.0


class Leases:
    """key -> holder -> expiry (monotonic)."""

    def __init__(self) -> None:
        self._expiry: dict[str, dict[str, float]] = {}

    def renew(self, key: str, holder: str) -> None:
        self._expiry.setdefault(key, {})[holder] = time.monotonic() + LEASE_S

    def drop(self, key: str, holder: str) -> None:
        self._expiry.get(key, {}).pop(holder, None)

    def keep_only(self, holder: str, keys: Iterable[str]) -> None:
        """``holder`` holds nothing but ``keys`` (renewed separately)."""
        kept = set(keys)
        for key, holders in self._expiry.items():
            if key not in kept:
                holders.pop(holder, None)

    def expire(self) -> list[str]:
        """Forget the leases that ran out; the keys nobody holds any more."""
        now = time.monotonic()
        gone = []
        for key, holders in list(self._expiry.items()):
            for holder in [h for h, expiry in holders.items() if expiry <= now]:
                del holders[holder]
            if not holders:
                del self._expiry[key]
                gone.append(key)
        return gone

    def holders(self, key: str) -> set[str]:
        return set(self._expiry.get(key, ()))

    def __contains__(self, key: object) -> bool:
        return key in self._expiry

    def __bool__(self) -> bool:
        return bool(self._expiry)
