"""Check poses against the latest map before anything goes to the robot."""

from __future__ import annotations

import math
from typing import Any

from robot.commands.pipeline import InvalidCommand
from robot.link.bus import RobotError
from robot.live.announce import aget_state
from robot.live.groups import MAP_META_KEY
from robot.navigation.mapimage import OCCUPIED_AT, UNKNOWN, cell_value, map_dir
from robot.navigation.transforms import MapGeometry, map_bounds, map_to_cell, map_to_cell_coords


class NoMap(RobotError):
    status_code = 503
    code = "no_map"


def number(value: Any, field: str, *, default: float | None = None) -> float:
    """A finite float from JSON input (numbers or numeric strings), or InvalidCommand naming the field."""
    if value is None or value == "":
        if default is not None:
            return default
        raise InvalidCommand(f"{field} is required", field=field)
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise InvalidCommand(f"{field} must be a number", field=field)
    try:
        result = float(value)
    except ValueError:
        raise InvalidCommand(f"{field} must be a number, got {value!r}", field=field) from None
    if not math.isfinite(result):
        raise InvalidCommand(f"{field} must be a finite number, got {value!r}", field=field)
    return result


YAW_LIMIT = 2 * math.pi
POSE_FIELDS = frozenset({"x", "y", "yaw"})


def clean_yaw(value: Any, *, default: float = 0.0) -> float:
    """A heading in radians within (-2π, 2π] (0 = +x, counter-clockwise), or InvalidCommand."""
    result = number(value, "yaw", default=default)
    if not -YAW_LIMIT < result <= YAW_LIMIT:
        raise InvalidCommand(f"yaw must be in radians within (-2π, 2π], got {result:g}", field="yaw")
    return result


def only_fields(data: dict[str, Any], allowed: frozenset[str]) -> None:
    """Refuse input with fields this command does not take (a typo must not pass as a default)."""
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise InvalidCommand(f"{unknown[0]}: unknown field; this takes {', '.join(sorted(allowed))}",
                             field=unknown[0])


def audit_params(**values: Any) -> dict[str, Any]:
    """Input as the audit entry keeps it: NaN and infinities are not JSON, so keep their text."""
    return {k: v if not isinstance(v, float) or math.isfinite(v) else repr(v) for k, v in values.items()}


async def acurrent_map() -> dict[str, Any]:
    meta = (await aget_state(MAP_META_KEY)).get(MAP_META_KEY)
    if not meta:
        raise NoMap("No map from the robot yet, so the position cannot be checked; try again in a moment.")
    return meta


async def acheck_position(x: float, y: float, *, allow_unknown: bool = False) -> dict[str, Any]:
    """Refuse points off the latest map, on obstacles, or (unless allowed) in unknown space."""
    meta = await acurrent_map()
    g = MapGeometry.from_meta(meta)
    where = f"({x:.2f}, {y:.2f})"
    cell = map_to_cell(g, x, y)
    if cell is None:
        col, _ = map_to_cell_coords(g, x, y)
        x0, y0, x1, y1 = map_bounds(g)
        raise InvalidCommand(
            f"{where} is off the map, which spans x {x0:.2f}…{x1:.2f} m and y {y0:.2f}…{y1:.2f} m",
            field="x" if not 0 <= col < g.width else "y",
        )
    value = cell_value(map_dir(), meta["version"], *cell)
    if value is None:
        raise NoMap("The latest map is not on this server's disk yet; try again in a moment.")
    if value == UNKNOWN and not allow_unknown:
        raise InvalidCommand(f"{where} is in unexplored space on the map; pick a free (white) spot", field="x")
    if value >= OCCUPIED_AT:
        raise InvalidCommand(f"{where} is on an obstacle ({value}% occupied); pick a free (white) spot", field="x")
    return meta
