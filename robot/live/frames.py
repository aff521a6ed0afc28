"""The JSON frames the live websocket sends, built from pre-serialised parts.

An update is serialised once per process (``update_fragment``); a socket's frame for a UI tick
joins the fragments of every key that changed (``batch_frame``), so no update is encoded per socket.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from typing import Any

from robot.live.state import jsonable, status_view

_COMPACT = (",", ":")


def update_fragment(update: dict[str, Any]) -> str:
    """The browser's view of one update: ``{"key":…,"msg":…,"t":…}``."""
    return json.dumps({"key": update["key"], "msg": update["msg"], "t": update["t"]},
                      default=jsonable, separators=_COMPACT)


def batch_frame(fragments: Iterable[str]) -> str:
    """One frame with every pending update of a socket: ``{"kind":"updates","updates":[…]}``."""
    return '{"kind":"updates","updates":[' + ",".join(fragments) + "]}"


def ws_text_frame(text: str) -> bytes:
    """``text`` as one unfragmented, unmasked websocket text frame (RFC 6455, 5.2): what a server
    sends, the same bytes for every connection."""
    return ws_frame(text.encode(), 0x81)


def ws_frame(payload: bytes, first: int) -> bytes:
    """One unmasked websocket frame: ``first`` is 0x81 for text, 0x82 for binary."""
    n = len(payload)
    if n < 126:
        header = bytes((first, n))
    elif n < 1 << 16:
        header = bytes((first, 126)) + n.to_bytes(2, "big")
    else:
        header = bytes((first, 127)) + n.to_bytes(8, "big")
    return header + payload


def status_text(status: dict[str, Any] | None) -> str:
    """The link's status as the browser sees it (offline when the link stopped reporting)."""
    view = status_view(status)
    return json.dumps({"kind": "status", **{k: v for k, v in view.items() if k != "type"}}, separators=_COMPACT)
