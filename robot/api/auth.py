"""Token login for scripts: POST {username, password} -> {token}."""

from __future__ import annotations

from drf_spectacular.utils import extend_schema, inline_serializer
from rest_framework import serializers
from rest_framework.authtoken.views import ObtainAuthToken

from robot.api.common import error_responses


class TokenView(ObtainAuthToken):
    # No session authentication, hence no CSRF check: scripts have no cookie to protect.
    authentication_classes: list = []

    @extend_schema(
        summary="Get an API token",
        description="Exchange a username and password for a token; send it as `Authorization: Token <token>`.",
        request=inline_serializer("TokenIn", {"username": serializers.CharField(),
                                              "password": serializers.CharField()}),
        responses={200: inline_serializer("TokenOut", {"token": serializers.CharField()}), **error_responses(400)},
        tags=["auth"],
    )
    def post(self, request, *args, **kwargs):
        return super().post(request, *args, **kwargs)
