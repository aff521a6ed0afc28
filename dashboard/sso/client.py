"""The OpenID Connect protocol, by Authlib: the redirect to the provider (state, nonce and a PKCE
challenge kept in the session), and the way back (state popped, so a replay fails; the code
exchanged with the verifier; the ID token's signature checked against the provider's keys, fetched
again when it names a key not yet seen; issuer, audience, expiry and nonce checked)."""

from __future__ import annotations

import functools
from typing import Any

import requests
from authlib.common.errors import AuthlibBaseError
from authlib.integrations.base_client import OAuthError
from authlib.integrations.django_client import OAuth
from django.http import HttpRequest, HttpResponse
from joserfc.errors import JoseError

from dashboard.sso.config import SsoConfig

# What a bad, forged or replayed answer raises, or a provider that cannot be reached.
REFUSALS = (AuthlibBaseError, JoseError, requests.RequestException, KeyError, ValueError)
TIMEOUT_S = 10


@functools.cache
def _app(config: SsoConfig) -> Any:
    registry = OAuth()
    return registry.register(
        "sso", client_id=config.client_id, client_secret=config.client_secret,
        server_metadata_url=config.metadata_url,
        client_kwargs={"scope": config.scopes, "code_challenge_method": "S256", "timeout": TIMEOUT_S},
    )


def redirect_to_provider(config: SsoConfig, request: HttpRequest, callback_url: str) -> HttpResponse:
    return _app(config).authorize_redirect(request, callback_url)


def claims_from_callback(config: SsoConfig, request: HttpRequest) -> tuple[dict[str, Any], str]:
    """The verified ID token's claims and the token itself (for logging out at the provider).
    Raises one of ``REFUSALS``."""
    # (Authlib checks the audience only through ``azp`` unless told: a token for another client
    # naming this one as its authorised party would pass.)
    must_be = {"iss": {"essential": True, "value": config.issuer},
               "aud": {"essential": True, "value": config.client_id}}
    token = _app(config).authorize_access_token(request, leeway=config.leeway_s, claims_options=must_be)
    claims = token.get("userinfo")
    if not claims:
        raise OAuthError(error="no_id_token", description="the provider sent no ID token")
    return dict(claims), str(token["id_token"])


def provider_logout_url(config: SsoConfig, *, id_token: str, then: str) -> str | None:
    """Where to send the browser to end the provider's session too (None: it offers no logout)."""
    app = _app(config)
    if not app.load_server_metadata().get("end_session_endpoint"):
        return None
    return str(app.create_logout_url(post_logout_redirect_uri=then, id_token_hint=id_token)["url"])
