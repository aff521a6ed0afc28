"""Replay: the robot as it was at a moment, read from the same history as the plots.

``state_at`` is a seek: the latest recorded value of each replayed topic at or before ``t``
(one indexed query per topic on ``(topic, received_at)``), the map of that time, the pose
trail and goal, the log lines and commands (with who) before it, and its camera frame.
``window`` is what a player needs to run on from there without asking again: every change in
(start, end], in time order.
"""

from __future__ import annotations

from collections.abc import Iterable
from functools import lru_cache
from pathlib import Path
from typing import Any

from django.conf import settings
from django.db import connection
from django.db.models import Max, Min, QuerySet
from django.urls import reverse

from history import replay_modes
from history.frames import frame_at
from history.models import CameraFrame, Incident, Sample
from history.storage import utc
from robot import interface as ri
from robot.models import AuditEntry
from robot.navigation.mapimage import render_map
from robot.navigation.transforms import quaternion_to_yaw

# What the Dashboard and Map show, replayed.
STATE_KEYS = (
    "robot_pose", "state_change", "robot_mode", "emotional_state", "battery_soc", "battery_voltage",
    "motors_state", "bumper_state", "move_base_status", "plan", "diagnostics", "current_location",
)
TRAIL_S = 60.0
LOG_BEFORE_S = 300.0
LOG_LINES = 30
COMMANDS_BEFORE_S = 600.0
COMMANDS = 20
PLAN_FRESH_S = 30.0
MAX_WINDOW_S = 300.0


def topic_names(keys: Iterable[str], hidden: frozenset[str] = frozenset()) -> dict[str, str]:
    return {name: key for key in keys if (name := ri.topic(key).name) not in hidden}


def latest_each(topics: Iterable[str], t: float) -> dict[str, dict[str, Any]]:
    """The newest sample of each topic at or before ``t``: one statement of one indexed
    ``ORDER BY ... DESC LIMIT 1`` per topic (a query per topic costs the ORM's overhead each)."""
    names = list(topics)
    if not names:
        return {}
    table = Sample._meta.db_table
    one = (f"SELECT * FROM (SELECT id, topic, received_at, data FROM {table} WHERE topic = %s AND received_at <= %s"
           " ORDER BY received_at DESC LIMIT 1) AS s{}")
    sql = " UNION ALL ".join(one.format(i) for i in range(len(names)))
    at = connection.ops.adapt_datetimefield_value(utc(t))
    rows = Sample.objects.raw(sql, [value for name in names for value in (name, at)])
    return {row.topic: {"t": row.received_at.timestamp(), "msg": row.data} for row in rows}


def pose_point(t: float, msg: dict[str, Any]) -> list[float] | None:
    position, orientation = msg.get("position") or {}, msg.get("orientation") or {}
    try:
        return [round(t, 3), float(position["x"]), float(position["y"]), round(quaternion_to_yaw(orientation), 4)]
    except (KeyError, TypeError, ValueError):
        return None


def goal_of(plan: dict[str, Any] | None, status: dict[str, Any] | None, t: float) -> dict[str, float] | None:
    """The goal being driven to: the end of a fresh plan while move_base has an active goal."""
    if not plan or t - plan["t"] > PLAN_FRESH_S:
        return None
    active = any(s.get("status") == 1 for s in ((status or {}).get("msg") or {}).get("status_list") or ())
    poses = (plan["msg"] or {}).get("poses") or []
    if not active or not poses:
        return None
    end = (poses[-1].get("pose") or {}).get("position") or {}
    return {"x": float(end.get("x", 0.0)), "y": float(end.get("y", 0.0))}


def _in_order(rows: QuerySet[Any, Any], *order: str, limit: int | None) -> list[Any]:
    """``rows`` in time order: all of them, or the last ``limit``."""
    if limit is None:
        return list(rows.order_by(*order))
    return list(rows.order_by(*(f"-{field}" for field in order))[:limit])[::-1]


def log_lines(start: float, end: float, limit: int | None = None) -> list[dict[str, Any]]:
    rows = Sample.objects.filter(topic=ri.topic("rosout").name, received_at__gt=utc(start), received_at__lte=utc(end))
    picked = _in_order(rows.values_list("received_at", "data"), "received_at", limit=limit)
    return [{"t": at.timestamp(), "level": ri.LOG_LEVELS.get(d.get("level"), str(d.get("level"))),
             "name": d.get("name", ""), "msg": d.get("msg", "")} for at, d in picked]


def commands(start: float, end: float, limit: int | None = None) -> list[dict[str, Any]]:
    picked = _in_order(AuditEntry.objects.filter(created__gt=utc(start), created__lte=utc(end)), "created", "id",
                       limit=limit)
    return [{"id": e.pk, "t": e.created.timestamp(), "who": e.username or "system", "action": e.action,
             "params": e.params, "ok": e.ok, "outcome": e.outcome} for e in picked]


def trail(start: float, end: float) -> list[list[float]]:
    rows = Sample.objects.filter(topic=ri.topic("robot_pose").name, received_at__gt=utc(start),
                                 received_at__lte=utc(end)).order_by("received_at").values_list("received_at", "data")
    points = [pose_point(at.timestamp(), d) for at, d in rows]
    return [p for p in points if p is not None]


def frame_info(frame: CameraFrame | None) -> dict[str, Any] | None:
    return None if frame is None else {"id": frame.pk, "t": frame.t, "url": frame_url(frame.pk)}


def frame_url(frame_id: int) -> str:
    return reverse("history-frame", args=[frame_id])


def map_at(t: float) -> dict[str, Any] | None:
    sample_id = (Sample.objects.filter(topic=ri.topic("map").name, received_at__lte=utc(t))
                 .order_by("-received_at").values_list("id", flat=True).first())
    if sample_id is None:
        return None
    version, geometry = rendered_map(sample_id)
    return {"id": sample_id, "version": version, "url": reverse("history-replay-map", args=[sample_id]), **geometry}


def replay_map_dir() -> Path:
    return Path(settings.VAR_DIR) / "replay-maps"


@lru_cache(maxsize=32)
def rendered_map(sample_id: int) -> tuple[str, dict[str, Any]]:
    """(version, geometry) of a recorded map, rendered once to ``replay_map_dir``."""
    msg = Sample.objects.values_list("data", flat=True).get(pk=sample_id)
    rendered = render_map(msg, replay_map_dir())
    g = rendered.geometry
    return rendered.version, {"width": g.width, "height": g.height, "resolution": g.resolution,
                              "origin": {"x": g.origin_x, "y": g.origin_y, "yaw": g.origin_yaw}}


def map_png(sample_id: int) -> Path:
    path = replay_map_dir() / f"{rendered_map(sample_id)[0]}.png"
    if not path.exists():  # pruned by a newer render: draw it again
        rendered_map.cache_clear()
        path = replay_map_dir() / f"{rendered_map(sample_id)[0]}.png"
    return path


def state_at(t: float, *, hidden: frozenset[str] = frozenset()) -> dict[str, Any]:
    """The robot as it was at ``t``; topics named in ``hidden`` (sensitive for this person) left out."""
    names = topic_names(STATE_KEYS, hidden)
    topics = {names[name]: value for name, value in latest_each(names, t).items()}
    if (request := replay_modes.request_at(t, topics.get("robot_mode"))) is not None:
        topics[replay_modes.REQUEST_KEY] = request
    if (change := topics.get("state_change")) is not None:
        topics[replay_modes.REACHED_KEY] = {"t": change["t"], "msg": replay_modes.reached(change["msg"])}
    pose = topics.get("robot_pose")
    return {
        "t": t,
        "topics": topics,
        "pose": pose_point(pose["t"], pose["msg"]) if pose else None,
        "trail": trail(t - TRAIL_S, t) if "robot_pose" in topics else [],
        "goal": goal_of(topics.get("plan"), topics.get("move_base_status"), t),
        "map": map_at(t),
        "log": log_lines(t - LOG_BEFORE_S, t, LOG_LINES) if ri.topic("rosout").name not in hidden else [],
        "commands": commands(t - COMMANDS_BEFORE_S, t, COMMANDS),
        "frame": frame_info(frame_at(t)),
    }


def window(start: float, end: float, *, hidden: frozenset[str] = frozenset()) -> dict[str, Any]:
    """Every change in (start, end] (at most ``MAX_WINDOW_S``), for a player to run through."""
    end = min(end, start + MAX_WINDOW_S)
    names = topic_names(STATE_KEYS, hidden)
    rows = (Sample.objects.filter(topic__in=list(names), received_at__gt=utc(start), received_at__lte=utc(end))
            .order_by("received_at").values_list("topic", "received_at", "data"))
    changes: list[list[Any]] = []
    poses: list[list[float]] = []
    for topic, at, data in rows:
        key = names[topic]
        if key == "robot_pose":
            if (point := pose_point(at.timestamp(), data)) is not None:
                poses.append(point)
        else:
            changes.append([round(at.timestamp(), 3), key, data])
            if key == "state_change":
                changes.append([round(at.timestamp(), 3), replay_modes.REACHED_KEY, replay_modes.reached(data)])
    requests = replay_modes.requests(start, end, hidden=hidden)
    changes += [[round(at, 3), replay_modes.REQUEST_KEY, msg] for at, msg in requests]
    changes.sort(key=lambda change: change[0])
    frames = CameraFrame.objects.filter(t__gt=start, t__lte=end).order_by("t").values_list("t", "id")
    prefix = frame_url(0).removesuffix("0.jpg")
    maps = Sample.objects.filter(topic=ri.topic("map").name, received_at__gt=utc(start), received_at__lte=utc(end))
    return {
        "start": start, "end": end, "poses": poses, "changes": changes,
        "log": log_lines(start, end) if ri.topic("rosout").name not in hidden else [],
        "commands": commands(start, end),
        "frames": [[round(ft, 3), fid, f"{prefix}{fid}.jpg"] for ft, fid in frames],
        "maps": [map_at(at.timestamp()) for at in maps.values_list("received_at", flat=True)],
    }


def span() -> dict[str, float | None]:
    """The first and last recorded moment (of the pose, the state and the camera)."""
    names = list(topic_names(("robot_pose", "state_change", "robot_mode")))
    samples = Sample.objects.filter(topic__in=names).aggregate(first=Min("received_at"), last=Max("received_at"))
    frames = CameraFrame.objects.aggregate(first=Min("t"), last=Max("t"))
    firsts = [v for v in (samples["first"] and samples["first"].timestamp(), frames["first"]) if v]
    lasts = [v for v in (samples["last"] and samples["last"].timestamp(), frames["last"]) if v]
    return {"first": min(firsts) if firsts else None, "last": max(lasts) if lasts else None}


LAST_MOMENT_S = 253_402_300_799.0  # 9999-12-31 23:59:59 UTC, the last a datetime holds


def parse_time(text: str | None) -> float | None:
    try:
        value = float(text or "")
    except ValueError:
        return None
    return value if 0 < value <= LAST_MOMENT_S else None


DEFAULT_RANGE_S = 600.0


def replay_start(incident: str | None, audit: str | None, t: str | None, start: str | None,
                 end: str | None) -> dict[str, Any]:
    """Where a replay page opens: an incident's window, the minutes around an audit row, a given
    range or moment, else the last ten recorded minutes."""
    if incident and incident.isdigit() and (found := Incident.objects.filter(pk=int(incident)).first()):
        return {"start": found.start, "end": found.end, "t": found.t, "incident": found.pk}
    if audit and audit.isdigit() and (entry := AuditEntry.objects.filter(pk=int(audit)).first()):
        moment = entry.created.timestamp()
        return {"start": moment - 120.0, "end": moment + 60.0, "t": moment, "audit": entry.pk}
    lo, hi, at = parse_time(start), parse_time(end), parse_time(t)
    if lo and hi and hi > lo:
        return {"start": lo, "end": hi, "t": min(max(at or lo, lo), hi)}
    if at:
        return {"start": at - DEFAULT_RANGE_S / 2, "end": at + DEFAULT_RANGE_S / 2, "t": at}
    last = float(span()["last"] or 0.0)
    return {"start": last - DEFAULT_RANGE_S, "end": last, "t": last - DEFAULT_RANGE_S}
