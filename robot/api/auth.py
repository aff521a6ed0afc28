"""Token login for scripts: POST {username, password} -> {token}, throttled like the login form; with
single sign-on required, a password gives one only to a break-glass account, and a signed-in session
gets one for itself (an empty POST)."""

from __future__ import annotations

from typing import Any

from django.conf import settings
from drf_spectacular.utils import extend_schema, inline_serializer
from rest_framework import exceptions, serializers
from rest_framework.authentication import SessionAuthentication
from rest_framework.authtoken.views import ObtainAuthToken
from rest_framework.request import Request
from rest_framework.response import Response

from cyborg_site.roles import may_sign_in_with_password
from robot.api.common import error_responses
from robot.api.tokens import expires_at, token_for


def lockout_message(*, flooded: bool = False) -> str:
    minutes = settings.AXES_COOLOFF_TIME.total_seconds() / 60
    if flooded:
        return ("This account has had many failed logins from elsewhere: for now it takes a password only "
                "in a browser that has logged in to it before. Use that one, try again in "
                f"{minutes:g} minutes, or ask an admin to clear the failed logins.")
    return (f"Too many failed logins from this account or address: try again in {minutes:g} minutes, "
            "or ask an admin to clear the lockout.")


class LockedOut(exceptions.Throttled):
    default_code = "locked_out"

    def __init__(self, *, flooded: bool = False) -> None:
        super().__init__(wait=settings.AXES_COOLOFF_TIME.total_seconds(), detail=lockout_message(flooded=flooded))


class PasswordNotAccepted(exceptions.PermissionDenied):
    default_code = "sso_required"

    def __init__(self) -> None:
        super().__init__(f"Sign in with {settings.OIDC_NAME}: a password gives an API token "
                         "only to a break-glass account. Get one from your account page, or POST here with an empty "
                         "body from your signed-in session.")


class TokenView(ObtainAuthToken):
    # A session (with its CSRF check) only for one's own token; scripts send no cookie, so no CSRF check.
    authentication_classes = [SessionAuthentication]

    @extend_schema(
        summary="Get an API token",
        description="Exchange a username and password for a token; send it as `Authorization: Token <token>`. "
                    "After `LOGIN_FAILURE_LIMIT` failures for one account or from one address, both are refused "
                    "(429, code `locked_out`) for `LOGIN_LOCKOUT_MINUTES`, even with the right password. "
                    "A token expires `API_TOKEN_DAYS` after it was made (`expires`; asking again then gives a "
                    "new one) and dies with a password change. With `SSO_REQUIRED=true` a password gives a token "
                    "only to a break-glass account (403, code `sso_required`); a signed-in session (cookie and "
                    "`X-CSRFToken`) gets its own with an empty body.",
        request=inline_serializer("TokenIn", {"username": serializers.CharField(required=False),
                                              "password": serializers.CharField(required=False)}),
        responses={200: inline_serializer("TokenOut", {"token": serializers.CharField(),
                                                       "expires": serializers.DateTimeField(allow_null=True)}),
                   **error_responses(400, 403, 429)},
        tags=["auth"],
    )
    def post(self, request: Request, *args: Any, **kwargs: Any) -> Response:
        if request.user.is_authenticated and not request.data:
            token = token_for(request.user)
            return Response({"token": token.key, "expires": expires_at(token)})
        serializer = self.get_serializer(data=request.data)
        try:
            serializer.is_valid(raise_exception=True)
        except exceptions.ValidationError:
            # django-axes flags the request when the account or address is locked out.
            if getattr(request, "axes_locked_out", False):
                raise LockedOut(flooded=getattr(request, "login_flooded", False)) from None
            raise
        user = serializer.validated_data["user"]
        if not may_sign_in_with_password(user):
            raise PasswordNotAccepted()
        token = token_for(user)
        return Response({"token": token.key, "expires": expires_at(token)})
