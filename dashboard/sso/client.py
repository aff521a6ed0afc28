"""The OpenID Connect protocol, by Authlib: the redirect to the provider (state, nonce and a PKCE
challenge kept in the session), and the way back (state popped, so a replay fails; the code
exchanged with the verifier; the ID token's signature checked against the provider's keys, fetched
again when it names a key not yet seen; issuer, audience, expiry and nonce checked; then the claims
the ID token lacks asked of the userinfo endpoint and of distributed claims' sources, see ``claims``)."""

from __future__ import annotations

import functools
from typing import Any

import requests
from authlib.common.errors import AuthlibBaseError
from authlib.integrations.base_client import OAuthError
from authlib.integrations.django_client import OAuth
from django.http import HttpRequest, HttpResponse
from joserfc import jwt
from joserfc.errors import InvalidKeyIdError, JoseError
from joserfc.jwk import KeySet
from joserfc.jws import JWSRegistry

from dashboard.sso.claims import ClaimsRefused, merged_with_userinfo, missing, resolved
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
    """The person's claims (the verified ID token's, completed) and the ID token itself (for logging
    out at the provider). Raises one of ``REFUSALS`` (the answer is broken or the provider away), or
    ``ClaimsRefused`` (the claims could not be completed)."""
    # (Authlib checks the audience only through ``azp`` unless told: a token for another client
    # naming this one as its authorised party would pass.)
    must_be = {"iss": {"essential": True, "value": config.issuer},
               "aud": {"essential": True, "value": config.client_id}}
    token = _app(config).authorize_access_token(request, leeway=config.leeway_s, claims_options=must_be)
    id_claims = token.get("userinfo")
    if not id_claims:
        raise OAuthError(error="no_id_token", description="the provider sent no ID token")
    return _completed(config, dict(id_claims), token), str(token["id_token"])


def _completed(config: SsoConfig, id_claims: dict[str, Any], token: dict[str, Any]) -> dict[str, Any]:
    app = _app(config)
    claims = resolved(id_claims, config, verified=lambda value: _verified(app, value), fetched=_fetched)
    if not missing(claims, config) or not app.load_server_metadata().get("userinfo_endpoint"):
        return claims
    try:
        userinfo = dict(app.userinfo(token=token, timeout=TIMEOUT_S))
    except (requests.RequestException, ValueError) as exc:
        raise ClaimsRefused(f"the provider's userinfo endpoint did not answer ({reason_of(exc)})") from exc
    userinfo = resolved(userinfo, config, verified=lambda value: _verified(app, value), fetched=_fetched)
    return merged_with_userinfo(claims, userinfo)


def _verified(app: Any, value: str) -> dict[str, Any]:
    """A claims JWT's claims, once its signature is checked against the provider's published keys."""
    registry = JWSRegistry(algorithms=app.load_server_metadata().get("id_token_signing_alg_values_supported"),
                           strict_check_header=False)
    try:
        try:
            return dict(jwt.decode(value, KeySet.import_key_set(app.fetch_jwk_set()), registry=registry).claims)
        except InvalidKeyIdError:
            return dict(jwt.decode(value, KeySet.import_key_set(app.fetch_jwk_set(force=True)),
                                   registry=registry).claims)
    except (JoseError, ValueError) as exc:
        raise ClaimsRefused(f"a claims source's answer is not a JWT signed with the provider's keys ({reason_of(exc)})",
                            forged=True) from exc


def _fetched(endpoint: str, access_token: str) -> str:
    try:
        answer = requests.get(endpoint, headers={"Authorization": f"Bearer {access_token}"}, timeout=TIMEOUT_S)
        answer.raise_for_status()
    except requests.RequestException as exc:
        raise ClaimsRefused(f"the claims source {endpoint} did not answer ({reason_of(exc)})") from exc
    return answer.text.strip()


def reason_of(exc: Exception) -> str:
    """What went wrong, in a line for the person and the audit."""
    return (str(getattr(exc, "description", "") or exc) or type(exc).__name__)[:200]


def provider_logout_url(config: SsoConfig, *, id_token: str, then: str) -> str | None:
    """Where to send the browser to end the provider's session too (None: it offers no logout)."""
    app = _app(config)
    if not app.load_server_metadata().get("end_session_endpoint"):
        return None
    return str(app.create_logout_url(post_logout_redirect_uri=then, id_token_hint=id_token)["url"])
