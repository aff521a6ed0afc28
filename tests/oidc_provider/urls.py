"""URLs of the tests' OpenID Connect provider: DOT under ``/o/``, the login form, and the control
endpoints under ``/test/`` that only this provider has (key rotation, the signing keys)."""

from __future__ import annotations

import hmac
import threading
from collections.abc import Callable

from django.conf import settings
from django.contrib.auth.views import LoginView
from django.http import HttpRequest, HttpResponse, JsonResponse
from django.urls import include, path
from django.views.decorators.csrf import csrf_exempt
from django.views.decorators.http import require_GET, require_POST
from oauth2_provider.settings import oauth2_settings
from oauth2_provider.utils import jwk_from_pem

from tests.oidc_provider.settings import new_rsa_pem

_rotation = threading.Lock()


def _controlled(view: Callable[[HttpRequest], HttpResponse]) -> Callable[[HttpRequest], HttpResponse]:
    def checked(request: HttpRequest) -> HttpResponse:
        given = request.headers.get("X-Test-Control", "")
        if not hmac.compare_digest(given.encode(), settings.SPEC["control_token"].encode()):
            return JsonResponse({"error": "bad control token"}, status=403)
        return view(request)

    return csrf_exempt(checked)


def _keys() -> dict[str, str | list[str]]:
    return {"active": oauth2_settings.OIDC_RSA_PRIVATE_KEY,
            "inactive": list(oauth2_settings.OIDC_RSA_PRIVATE_KEYS_INACTIVE)}


@_controlled
@require_POST
def rotate_key(request: HttpRequest) -> HttpResponse:
    """A fresh key signs from now on; the previous one stays published, the one before it goes."""
    with _rotation:
        pem = new_rsa_pem()
        inactive = [oauth2_settings.OIDC_RSA_PRIVATE_KEY]
        settings.OAUTH2_PROVIDER.update(OIDC_RSA_PRIVATE_KEY=pem, OIDC_RSA_PRIVATE_KEYS_INACTIVE=inactive)
        oauth2_settings.OIDC_RSA_PRIVATE_KEYS_INACTIVE = inactive
        oauth2_settings.OIDC_RSA_PRIVATE_KEY = pem
    return JsonResponse({"kid": jwk_from_pem(pem).thumbprint()})


@_controlled
@require_GET
def keys(request: HttpRequest) -> HttpResponse:
    return JsonResponse(_keys())


def home(request: HttpRequest) -> HttpResponse:
    who = f"Signed in as {request.user.get_username()}" if request.user.is_authenticated else "Signed out"
    return HttpResponse(f"<!doctype html><title>Test provider</title><p>{who}</p>")


urlpatterns = [
    path("o/", include("oauth2_provider.urls", namespace="oauth2_provider")),
    path("accounts/login/", LoginView.as_view(), name="login"),
    path("test/rotate-key", rotate_key),
    path("test/keys", keys),
    path("", home),
]
