from typing import Any

from django.conf import settings
from django.http import HttpRequest
from django.urls import reverse

from cyborg_site.roles import is_admin, is_operator, role_of
from dashboard.preferences import theme
from dashboard.routing import LIVE_SOCKET_PATH
from robot.api.commands import COMMAND_VIEWS
from robot.estop.latch import latch


def roles(request: HttpRequest) -> dict[str, Any]:
    user = getattr(request, "user", None)
    return {
        "role": role_of(user),
        "can_command": is_operator(user),
        "can_admin": is_admin(user),
        "stale_after_s": settings.STALE_AFTER_S,
        "theme": theme(user) if user is not None else "system",
    }


def estop(request: HttpRequest) -> dict[str, Any]:
    """The E-STOP latch, so a page opened while it holds shows the banner from the start."""
    if not getattr(getattr(request, "user", None), "is_authenticated", False):
        return {}
    return {"estop": latch()}


def site_config(request: HttpRequest) -> dict[str, Any]:
    """What every page's scripts read from base.html's "site-config": URLs and the time policy."""
    return {
        "site_config": {
            "time_zone": settings.TIME_ZONE,
            "urls": {
                "live_socket": LIVE_SOCKET_PATH,
                "login": reverse("login"),
                "estop": reverse("robot-estop"),
                "estop_release": reverse("robot-estop-release"),
                "theme": reverse("api-theme"),
            },
            # The command API views the pages' command buttons post to, by their data-command name.
            "commands": {name: reverse(f"api-robot-{name}") for name in COMMAND_VIEWS},
        },
    }
