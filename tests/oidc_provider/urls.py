"""URLs of the tests' OpenID Connect provider: DOT under ``/o/``, the login form, and the control
endpoints under ``/test/`` that only this provider has (key rotation, the signing keys, a user's
groups, where the claims are given, a distributed claims' source, and a token endpoint that
misbehaves once, as a forged or broken provider answer would)."""

from __future__ import annotations

import base64
import hmac
import json
import threading
import time
from collections.abc import Callable

from django.conf import settings
from django.contrib.auth import get_user_model
from django.contrib.auth.views import LoginView
from django.http import HttpRequest, HttpResponse, JsonResponse
from django.urls import include, path
from django.views.decorators.csrf import csrf_exempt
from django.views.decorators.http import require_GET, require_POST
from jwcrypto import jwt
from oauth2_provider.settings import oauth2_settings
from oauth2_provider.utils import jwk_from_pem
from oauth2_provider.views import TokenView

from tests.oidc_provider.settings import new_rsa_pem
from tests.oidc_provider.validator import source_token

_rotation = threading.Lock()


def _controlled(view: Callable[..., HttpResponse]) -> Callable[..., HttpResponse]:
    def checked(request: HttpRequest, **kwargs: str) -> HttpResponse:
        given = request.headers.get("X-Test-Control", "")
        if not hmac.compare_digest(given.encode(), settings.SPEC["control_token"].encode()):
            return JsonResponse({"error": "bad control token"}, status=403)
        return view(request, **kwargs)

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


@_controlled
@require_POST
def set_groups(request: HttpRequest, username: str) -> HttpResponse:
    """The user's ``groups`` claim from now on (JSON list in the body)."""
    user = next(user for user in settings.SPEC["users"] if user["username"] == username)
    user["groups"] = json.loads(request.body)
    return JsonResponse({"groups": user["groups"]})


CLAIMS_AT = ("id_token", "userinfo", "distributed", "pointer_only", "userinfo_other_sub")


@_controlled
@require_POST
def set_claims_at(request: HttpRequest) -> HttpResponse:
    """Where e-mail and groups are given from now on (the body's ``where``, one of ``CLAIMS_AT``)."""
    where = json.loads(request.body)["where"]
    if where not in CLAIMS_AT:
        return JsonResponse({"error": f"where is one of {CLAIMS_AT}"}, status=400)
    settings.SPEC["claims_at"] = where
    return JsonResponse({"where": where})


@require_GET
def claims_source(request: HttpRequest, username: str) -> HttpResponse:
    """A distributed claims' source (OpenID Connect Core 5.6.2): the user's groups as a JWT signed
    with the active key, for the access token the claims named."""
    given = request.headers.get("Authorization", "").removeprefix("Bearer ")
    if not hmac.compare_digest(given.encode(), source_token(username).encode()):
        return JsonResponse({"error": "invalid_token"}, status=401)
    profile = next(user for user in settings.SPEC["users"] if user["username"] == username)
    subject = str(get_user_model().objects.get(username=username).pk)
    key = jwk_from_pem(oauth2_settings.OIDC_RSA_PRIVATE_KEY)
    token = jwt.JWT(header={"alg": "RS256", "kid": key.thumbprint()},
                    claims={"iss": settings.ISSUER, "sub": subject, "groups": list(profile["groups"])})
    token.make_signed_token(key)
    return HttpResponse(token.serialize(), content_type="application/jwt")


MISCHIEF = ("tampered", "wrong_audience", "wrong_issuer", "expired", "wrong_nonce", "unknown_key", "no_id_token")
_next_mischief: list[str] = []


@_controlled
@require_POST
def misbehave(request: HttpRequest) -> HttpResponse:
    """The token endpoint's next answer is broken the way the body's ``mischief`` says."""
    mischief = json.loads(request.body)["mischief"]
    if mischief not in MISCHIEF:
        return JsonResponse({"error": f"mischief is one of {MISCHIEF}"}, status=400)
    _next_mischief.append(mischief)
    return JsonResponse({"mischief": mischief})


def _b64(data: bytes) -> str:
    return base64.urlsafe_b64encode(data).rstrip(b"=").decode()


def _claims(id_token: str) -> dict:
    payload = id_token.split(".")[1]
    return json.loads(base64.urlsafe_b64decode(payload + "=" * (-len(payload) % 4)))


def _broken(id_token: str, mischief: str) -> str | None:
    claims = _claims(id_token)
    if mischief == "no_id_token":
        return None
    if mischief == "tampered":  # a claim changed after signing: the signature no longer fits
        header, _, signature = id_token.split(".")
        return ".".join((header, _b64(json.dumps({**claims, "groups": ["cyborg-admins"]}).encode()), signature))
    key = jwk_from_pem(oauth2_settings.OIDC_RSA_PRIVATE_KEY)
    if mischief == "unknown_key":
        from jwcrypto import jwk

        key = jwk.JWK.generate(kty="RSA", size=2048)
    # (The wrong audience names the client as its authorised party: the audience alone must refuse it.)
    changed = {"wrong_audience": {"aud": "another-client", "azp": settings.SPEC["client"]["client_id"]},
               "wrong_issuer": {"iss": "http://127.0.0.1:1/o"}, "wrong_nonce": {"nonce": "from-another-sign-in"},
               "expired": {"iat": int(time.time()) - 3600, "exp": int(time.time()) - 600}}.get(mischief, {})
    token = jwt.JWT(header={"alg": "RS256", "kid": key.thumbprint()}, claims={**claims, **changed})
    token.make_signed_token(key)
    return token.serialize()


@csrf_exempt
def token(request: HttpRequest) -> HttpResponse:
    """DOT's token endpoint, with the ID token broken once when a test asked for it."""
    response = TokenView.as_view()(request)
    if not _next_mischief or response.status_code != 200:
        return response
    answer = json.loads(response.content)
    broken = _broken(answer["id_token"], _next_mischief.pop(0))
    if broken is None:
        del answer["id_token"]
    else:
        answer["id_token"] = broken
    response.content = json.dumps(answer).encode()
    return response


def home(request: HttpRequest) -> HttpResponse:
    who = f"Signed in as {request.user.get_username()}" if request.user.is_authenticated else "Signed out"
    return HttpResponse(f"<!doctype html><title>Test provider</title><p>{who}</p>")


urlpatterns = [
    path("o/token/", token),
    path("o/", include("oauth2_provider.urls", namespace="oauth2_provider")),
    path("accounts/login/", LoginView.as_view(), name="login"),
    path("test/rotate-key", rotate_key),
    path("test/keys", keys),
    path("test/users/<str:username>/groups", set_groups),
    path("test/misbehave", misbehave),
    path("test/claims-at", set_claims_at),
    path("test/claims-source/<str:username>", claims_source),
    path("", home),
]
