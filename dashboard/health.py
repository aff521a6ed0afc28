"""What /healthz reports: one small check per backing service, and the robot link.

A check returns a ``Check`` (or None when it does not apply to this wiring); add one by
appending a function to ``CHECKS``. Any failing check makes /healthz answer 503.

Anyone (a load balancer, a script polling) sees whether each check and the robot link are up
(``public_report``); the addresses of the robot and the video server, the error texts and the
link's details only a logged-in staff member or an admin's API token (``may_see_details``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from django.conf import settings
from django.db import connection
from django.http import HttpRequest
from rest_framework.exceptions import AuthenticationFailed

from cyborg_site.roles import is_admin
from history.recorder import WATERMARK_KEY, losses
from robot.api.errors import UNAVAILABLE_TEXT, unavailable
from robot.api.tokens import CachedTokenAuthentication
from robot.live import redis_clients
from robot.live.state import get_store, link_status
from robot.supervisor import failing
from robot.uplink.status import describe as describe_uplink


@dataclass(frozen=True)
class Check:
    name: str
    ok: bool
    detail: str = ""


def check_database() -> Check:
    try:
        with connection.cursor() as cursor:
            cursor.execute("SELECT 1")
    except Exception as exc:
        if not unavailable(exc):
            raise
        return Check("database", False, f"{UNAVAILABLE_TEXT['database']}: {exc}")
    return Check("database", True)


def check_redis() -> Check:
    import redis

    # The product's own pooled client: healthy only when what commands use answers.
    try:
        redis_clients.client().ping()
    except (redis.ConnectionError, redis.TimeoutError) as exc:
        return Check("redis", False, f"{UNAVAILABLE_TEXT['redis']}: {exc}")
    return Check("redis", True, "embedded: this process's private server" if settings.EMBEDDED else "")


def check_command_path() -> Check | None:
    """A link that runs but does not answer its ping over the request channel (robot.link.hosting)."""
    try:
        status = link_status()
    except Exception as exc:
        if not unavailable(exc):
            raise
        return None  # the Redis check names the cause; the report's command_path says false
    if not status.get("link_running"):
        return None  # no link reports at all: "link_running" says so
    if not status["command_path"]:
        return Check("command_path", False, "Command path down: the robot link does not answer requests")
    return Check("command_path", True)


def check_audit() -> Check:
    """Entries are being journaled: every command but the E-STOP is refused until they are written."""
    from robot.commands.audit_writer import writer

    if writer.down:
        return Check("audit", False, "the audit log cannot be written: commands are refused, the E-STOP works")
    return Check("audit", True)


CHECKS: list[Callable[[], Check | None]] = [check_database, check_redis, check_command_path, check_audit]


def health_report() -> dict[str, Any]:
    checks = [check for run in CHECKS if (check := run()) is not None]
    down = [c.name for c in checks if not c.ok]
    report: dict[str, Any] = {
        "ok": not down,
        "down": down,
        "checks": {c.name: {"ok": c.ok, **({"detail": c.detail} if c.detail else {})} for c in checks},
    }
    # The robot being offline is reported, not a failure of this server.
    status = link_status() if "redis" not in down else {"connected": False, "url": settings.ROSBRIDGE_URL}
    report.update(connected=bool(status["connected"]), link_running=bool(status.get("link_running", False)),
                  command_path=bool(status.get("command_path", False)), robot_url=status.get("url") or "",
                  video_url=settings.VIDEO_URL, ros=status.get("ros"),
                  failing_tasks=[*status.get("failing_tasks", []), *failing()], link_holder=status.get("holder"),
                  failed_subscriptions=status.get("failed_subscriptions") or {},
                  uplink=status.get("uplink"), reached=describe_uplink(status.get("uplink")),
                  history_lost_in_handovers=_handover_losses() if "redis" not in down else {})
    return report


def _handover_losses() -> dict[str, int]:
    """Every-message recording lost between one recorder and the next (link failovers, restarts)."""
    try:
        return losses(get_store().get_all().get(WATERMARK_KEY))
    except Exception as exc:
        if not unavailable(exc):
            raise
        return {}


# Up or down, and nothing else: what anyone may see.
PUBLIC_FIELDS = ("ok", "down", "connected", "link_running", "command_path", "detail", "code")


def public_report(report: dict[str, Any]) -> dict[str, Any]:
    """``report`` without addresses, error texts or the link's details: each check up or down."""
    public = {name: report[name] for name in PUBLIC_FIELDS if name in report}
    public["checks"] = {name: {"ok": check["ok"]} for name, check in report["checks"].items()}
    return public


def may_see_details(request: HttpRequest) -> bool:
    """A logged-in staff member, or an admin's API token. Asks the database only when the request
    carries a session or a token, and says no when the database that knows them is down."""
    try:
        if request.META.get("HTTP_AUTHORIZATION"):
            found = CachedTokenAuthentication().authenticate(request)  # type: ignore[arg-type]
            user = found[0] if found else None
        else:
            user = request.user
        return bool(user is not None and user.is_active and (user.is_staff or is_admin(user)))
    except AuthenticationFailed:
        return False
    except Exception as exc:
        if not unavailable(exc):
            raise
        return False
