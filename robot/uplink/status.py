"""How the robot is reached, in words, for health and the pages."""

from __future__ import annotations

import time
from typing import Any


def clock(epoch: Any) -> str:
    """An epoch time as the audit and the pages write it."""
    return time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(float(epoch)))


def describe(uplink: dict[str, Any] | None) -> str:
    """"" when the server dials the robot itself (no uplink configured)."""
    if not uplink:
        return ""
    if uplink.get("connected"):
        return f"robot connected through its uplink from {uplink['address']} since {clock(uplink['since'])}"
    if uplink.get("last_address"):
        return (f"no uplink from the robot: the last one, from {uplink['last_address']}, ended "
                f"{clock(uplink['ended'])} ({uplink.get('why') or 'closed'}); is its agent running and online?")
    return uplink.get("why") or ("no uplink from the robot yet: is its uplink agent running (deploy/robot/) "
                                 "with a credential made in Admin → Uplink credentials?")
