"""Goal statuses as the pages show them: actionlib's ten codes folded into a few states."""

from __future__ import annotations

from typing import Any

from robot import interface as ri

# pending, active, succeeded, aborted, cancelled (+ cancelling, rejected, lost) for people.
_STATE_OF_CODE = {
    0: "pending", 1: "active", 2: "cancelled", 3: "succeeded", 4: "aborted",
    5: "rejected", 6: "cancelling", 7: "cancelling", 8: "cancelled", 9: "lost",
}
TERMINAL_STATES = frozenset({"succeeded", "aborted", "cancelled", "rejected", "lost"})
KEEP_GOALS = 20
# Every goal this product sends has an id that starts so; any other goal the robot lists was sent by another tool.
GOAL_ID_PREFIX = "cyborg_commander-"
FOREIGN_GOAL_BY = "another tool"


def goal_state(code: int) -> str:
    return _STATE_OF_CODE.get(code, ri.GOAL_STATUS.get(code, f"status {code}"))


def merge_statuses(known: dict[str, Any], messages: list[dict[str, Any]], *, now: float) -> dict[str, Any]:
    """Fold GoalStatusArray messages into ``{"goals": {id: {code, state, text, t, since, action}}}``
    (``since``: when the goal was first listed; ``action``: the message's, when it names one).

    Terminal statuses stay after the robot stops listing them, so a page opened later still
    sees how the last goal ended. Only the ``KEEP_GOALS`` most recently changed are kept.
    """
    goals = {gid: dict(s) for gid, s in known.get("goals", {}).items()}
    for msg in messages:
        for item in msg.get("status_list") or []:
            gid = (item.get("goal_id") or {}).get("id") or ""
            code = int(item.get("status", 0))
            if not gid:
                continue
            old = goals.get(gid)
            if old is None or old["code"] != code or old.get("text") != item.get("text", ""):
                goals[gid] = {"code": code, "state": goal_state(code), "text": item.get("text", ""), "t": now,
                              "since": (old or {}).get("since", now),
                              "action": msg.get("action") or (old or {}).get("action") or "move_base"}
    if len(goals) > KEEP_GOALS:
        goals = dict(sorted(goals.items(), key=lambda kv: kv[1]["t"], reverse=True)[:KEEP_GOALS])
    return {"goals": goals}


def is_ours(goal_id: str) -> bool:
    return goal_id.startswith(GOAL_ID_PREFIX)


def _newest_foreign(statuses: dict[str, Any] | None) -> tuple[str, dict[str, Any]] | None:
    foreign = [(gid, s) for gid, s in ((statuses or {}).get("goals") or {}).items() if not is_ours(gid)]
    return max(foreign, key=lambda item: item[1].get("since", item[1]["t"]), default=None)


def goal_view(goal: dict[str, Any] | None, statuses: dict[str, Any] | None) -> dict[str, Any] | None:
    """The current goal with its status: the latest goal wins, as on the robot, whether this product
    sent it (``goal``) or another tool did (a goal the robot lists under an id not ours, shown with
    ``foreign`` and no target: the status does not carry it). A goal the robot has not listed yet is pending."""
    foreign = _newest_foreign(statuses)
    if foreign and (not goal or foreign[1].get("since", foreign[1]["t"]) > goal["sent"]):
        gid, theirs = foreign
        return {"id": gid, "action": theirs.get("action", "move_base"), "x": None, "y": None, "yaw": None,
                "location": None, "by": FOREIGN_GOAL_BY, "sent": theirs.get("since", theirs["t"]),
                "cancel_requested": False, "foreign": True, "status": theirs["state"],
                "status_text": theirs.get("text", ""), "finished": theirs["state"] in TERMINAL_STATES}
    if not goal:
        return None
    reported = ((statuses or {}).get("goals") or {}).get(goal["id"])
    state = reported["state"] if reported else "pending"
    if goal.get("cancel_requested") and state in ("pending", "active"):
        state = "cancelling"
    return {**goal, "foreign": False, "status": state, "status_text": (reported or {}).get("text", ""),
            "finished": state in TERMINAL_STATES}
