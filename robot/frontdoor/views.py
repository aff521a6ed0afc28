"""POST /api/frontdoor/ticket/: a single-use connect ticket for a ROS tool (robot.frontdoor), asked for
with an API token or a signed-in session (single sign-on included)."""

from __future__ import annotations

from django.conf import settings
from drf_spectacular.utils import extend_schema, inline_serializer
from rest_framework import serializers
from rest_framework.request import Request
from rest_framework.response import Response

from robot.api.base import robot_api_view
from robot.api.common import error_responses
from robot.frontdoor import SOCKET_PATH
from robot.frontdoor.tickets import ticket_issue


def frontdoor_url(request: Request, ticket: str) -> str:
    """Where a tool connects with ``ticket``: this site's websocket scheme and host."""
    scheme = "wss" if request.is_secure() else "ws"
    return f"{scheme}://{request.get_host()}{SOCKET_PATH}?ticket={ticket}"


@extend_schema(
    summary="A connect ticket for a ROS tool",
    description="A ticket that lets one rosbridge v2 client (roslibjs, roslibpy, Foxglove, Lichtblick) in "
                "through the front door, once, within `expires_s` seconds. Connect to `url`.",
    request=None,
    responses={200: inline_serializer("FrontDoorTicketOut", {
        "ticket": serializers.CharField(), "url": serializers.CharField(),
        "expires_s": serializers.FloatField()}), **error_responses(401)},
)
@robot_api_view(["POST"])
def ticket_view(request: Request) -> Response:
    ticket = ticket_issue(user=request.user)
    return Response({"ticket": ticket, "url": frontdoor_url(request, ticket), "expires_s": settings.FRONTDOOR_TICKET_S})
