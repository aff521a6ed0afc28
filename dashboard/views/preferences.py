"""The signed-in person's page preferences (thin: dashboard.preferences does the work)."""

from __future__ import annotations

from drf_spectacular.utils import extend_schema, inline_serializer
from rest_framework import serializers
from rest_framework.request import Request
from rest_framework.response import Response

from dashboard.preferences import OVERLAY_NAMES, THEMES, map_overlays, set_map_overlays, set_theme, theme
from robot.api.base import robot_api_view
from robot.api.common import error_responses
from robot.api.validation import body_object

Overlays = inline_serializer(name="MapOverlays", fields={name: serializers.BooleanField() for name in OVERLAY_NAMES})


@extend_schema(methods=["GET"], responses={200: Overlays}, summary="Which map overlays you have switched on")
@extend_schema(methods=["PATCH"], request=Overlays, responses={200: Overlays, **error_responses(400)},
               summary="Switch map overlays on or off",
               description="Send only the overlays to change, each true or false; unknown names are refused.")
@robot_api_view(["GET", "PATCH"])
def map_overlays_view(request: Request) -> Response:
    if request.method == "PATCH":
        return Response(set_map_overlays(request.user, body_object(request)))
    return Response(map_overlays(request.user))


Theme = inline_serializer(name="Theme", fields={"theme": serializers.ChoiceField(choices=THEMES)})


@extend_schema(methods=["GET"], responses={200: Theme}, summary="Your colour theme")
@extend_schema(methods=["PATCH"], request=Theme, responses={200: Theme, **error_responses(400)},
               summary="Choose your colour theme",
               description="system follows the browser's light or dark setting; light and dark override it.")
@robot_api_view(["GET", "PATCH"])
def theme_view(request: Request) -> Response:
    if request.method == "PATCH":
        return Response({"theme": set_theme(request.user, body_object(request).get("theme"))})
    return Response({"theme": theme(request.user)})
