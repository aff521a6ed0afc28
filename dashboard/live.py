"""Frames the live websocket sends; one shape for the first snapshot and for updates."""

from __future__ import annotations

from typing import Any

from robot.live.state import status_view


def live_frame(update: dict[str, Any]) -> dict[str, Any]:
    return {"kind": "update", "key": update["key"], "msg": update["msg"], "t": update["t"]}


def status_frame(status: dict[str, Any] | None) -> dict[str, Any]:
    view = status_view(status)
    return {"kind": "status", **{k: v for k, v in view.items() if k != "type"}}
