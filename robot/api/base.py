"""One base for every robot API view: authentication (token first, then session), where a
request came from, one throttle for commands, and the one way a view runs a command.

Why a synchronous face rather than async views (adrf): Django's ORM is synchronous, and
everything around a command touches it (the token or session lookup, the role check, preset
names, the audit entry). An async view would cross to a thread for each of those; a
synchronous view does them all in the request's thread and crosses to the event loop once,
for the robot work (``robot.commands.pipeline.run_command``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from django.conf import settings
from rest_framework.authentication import SessionAuthentication
from rest_framework.decorators import api_view, authentication_classes, throttle_classes
from rest_framework.request import Request
from rest_framework.throttling import UserRateThrottle
from rest_framework.views import APIView

from robot.api.tokens import CachedTokenAuthentication
from robot.commands.pipeline import Command, run_command

# Token first: an anonymous caller gets 401 with ``WWW-Authenticate: Token`` (not a bare 403).
# Tokens are cached briefly (robot.api.tokens): a script polling the API costs no query per request.
API_AUTHENTICATION = [CachedTokenAuthentication, SessionAuthentication]


class CommandThrottle(UserRateThrottle):
    """Per-user rate limit shared by every command (``COMMAND_THROTTLE_RATE``), read at request time."""

    scope = "commands"

    def get_rate(self) -> str | None:
        return settings.COMMAND_THROTTLE_RATE


def source_of(request: Request) -> str:
    """Audit source: the pages post with the session; scripts authenticate with a token."""
    return "page" if isinstance(request.successful_authenticator, SessionAuthentication) else "api"


def run(request: Request, command: Command) -> str:
    """Run a command for this request's user through the pipeline's synchronous face."""
    return run_command(command, user=request.user, source=source_of(request))


class RobotAPIView(APIView):
    authentication_classes = API_AUTHENTICATION


class CommandAPIView(RobotAPIView):
    throttle_classes = [CommandThrottle]


def robot_api_view(methods: Sequence[str], *, commands: bool = False) -> Callable[[Callable[..., Any]], Any]:
    """``@api_view`` with the same authentication (and, for commands, the same throttle) as the classes."""

    def decorate(view: Callable[..., Any]) -> Any:
        view = authentication_classes(API_AUTHENTICATION)(view)
        if commands:
            view = throttle_classes([CommandThrottle])(view)
        return api_view(list(methods))(view)

    return decorate
