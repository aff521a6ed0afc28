"""The tests' OpenID Connect provider itself: discovery, the authorization-code flow with PKCE done
by hand with ``requests``, the ID token's claims and signature, and key rotation."""

from __future__ import annotations

import base64
import hashlib
import json
import re
import secrets
import time
from collections.abc import Iterator
from typing import Any
from urllib.parse import parse_qs, urlencode, urlsplit

import pytest
import requests
from jwcrypto import jwk, jws, jwt

from tests.oidc_provider.harness import OidcProvider, ProviderUser

CLIENT_ID = "cyborg"
CLIENT_SECRET = "s3cret"
REDIRECT_URI = "http://127.0.0.1:8123/accounts/sso/callback/"
SIGNED_OUT_URI = "http://127.0.0.1:8123/"
OLGA = ProviderUser("olga", "pw-olga", groups=["cyborg-operators", "staff"], email="olga@ntnu.no", name="Olga N.")


@pytest.fixture(scope="module")
def provider() -> Iterator[OidcProvider]:
    with OidcProvider(users=[OLGA, ProviderUser("vera", "pw-vera")], client_id=CLIENT_ID,
                      client_secret=CLIENT_SECRET, redirect_uris=[REDIRECT_URI],
                      post_logout_redirect_uris=[SIGNED_OUT_URI]) as running:
        yield running


def _discovery(provider: OidcProvider) -> dict[str, Any]:
    return requests.get(provider.discovery_url, timeout=5).json()


def _signed_in(provider: OidcProvider, user: ProviderUser) -> requests.Session:
    session = requests.Session()
    login_url = f"{provider.base_url}/accounts/login/"
    page = session.get(login_url, timeout=5)
    assert "Sign in" in page.text
    csrf = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page.text)
    assert csrf is not None
    answer = session.post(login_url, data={"csrfmiddlewaretoken": csrf[1], "username": user.username,
                                           "password": user.password}, allow_redirects=False, timeout=5)
    assert answer.status_code == 302, answer.text
    return session


def _authorize(provider: OidcProvider, session: requests.Session, **params: str) -> dict[str, str]:
    """The query of the provider's redirect back to the client, which is not contacted."""
    query = {"response_type": "code", "client_id": CLIENT_ID, "redirect_uri": REDIRECT_URI,
             "scope": "openid profile email", "state": secrets.token_urlsafe(8), **params}
    answer = session.get(f"{_discovery(provider)['authorization_endpoint']}?{urlencode(query)}",
                         allow_redirects=False, timeout=5)
    assert answer.status_code == 302, answer.text
    location = answer.headers["Location"]
    assert location.startswith(REDIRECT_URI)
    return {key: values[0] for key, values in parse_qs(urlsplit(location).query).items()}


def _id_token(provider: OidcProvider, user: ProviderUser, nonce: str) -> str:
    verifier = secrets.token_urlsafe(48)
    challenge = base64.urlsafe_b64encode(hashlib.sha256(verifier.encode()).digest()).rstrip(b"=").decode()
    session = _signed_in(provider, user)
    redirect = _authorize(provider, session, nonce=nonce, code_challenge=challenge, code_challenge_method="S256")
    assert redirect["iss"] == provider.issuer
    tokens = requests.post(_discovery(provider)["token_endpoint"], auth=(CLIENT_ID, CLIENT_SECRET), timeout=5, data={
        "grant_type": "authorization_code", "code": redirect["code"], "redirect_uri": REDIRECT_URI,
        "code_verifier": verifier})
    assert tokens.status_code == 200, tokens.text
    return tokens.json()["id_token"]


def _verified_claims(provider: OidcProvider, token: str) -> dict[str, Any]:
    keys = jwk.JWKSet.from_json(requests.get(provider.jwks_url, timeout=5).text)
    checked = jwt.JWT(jwt=token, key=keys, check_claims={"iss": provider.issuer, "aud": CLIENT_ID, "exp": None})
    return json.loads(checked.claims)


def _kid(token: str) -> str:
    unverified = jws.JWS()
    unverified.deserialize(token)
    return unverified.jose_header["kid"]


def _published_kids(provider: OidcProvider) -> list[str]:
    return [key["kid"] for key in requests.get(provider.jwks_url, timeout=5).json()["keys"]]


def test_discovery_names_the_endpoints_and_s256_only(provider: OidcProvider) -> None:
    discovery = _discovery(provider)
    assert discovery["issuer"] == provider.issuer == f"http://127.0.0.1:{provider.port}/o"
    base = provider.issuer
    assert discovery["authorization_endpoint"] == f"{base}/authorize/"
    assert discovery["token_endpoint"] == f"{base}/token/"
    assert discovery["jwks_uri"] == provider.jwks_url
    assert discovery["end_session_endpoint"] == f"{base}/logout/"
    assert discovery["code_challenge_methods_supported"] == ["S256"]
    assert {"groups", "email", "preferred_username"} <= set(discovery["claims_supported"])


def test_code_flow_with_pkce_gives_a_signed_id_token_with_the_users_claims(provider: OidcProvider) -> None:
    nonce = secrets.token_urlsafe(12)
    claims = _verified_claims(provider, _id_token(provider, OLGA, nonce))
    assert claims["nonce"] == nonce
    assert claims["preferred_username"] == "olga"
    assert claims["email"] == "olga@ntnu.no"
    assert claims["email_verified"] is True
    assert claims["name"] == "Olga N."
    assert claims["groups"] == ["cyborg-operators", "staff"]
    assert claims["sub"]
    assert 0 < claims["exp"] - time.time() <= 300


def test_a_user_without_groups_gets_an_empty_list(provider: OidcProvider) -> None:
    claims = _verified_claims(provider, _id_token(provider, ProviderUser("vera", "pw-vera"), "n"))
    assert claims["groups"] == []
    assert claims["name"] == "vera"


@pytest.mark.parametrize("pkce", [{}, {"code_challenge": "a" * 43, "code_challenge_method": "plain"}],
                         ids=["without challenge", "plain challenge"])
def test_authorization_without_an_s256_challenge_is_refused(provider: OidcProvider, pkce: dict[str, str]) -> None:
    redirect = _authorize(provider, _signed_in(provider, OLGA), nonce="n", **pkce)
    assert redirect["error"] == "invalid_request"
    assert "code" not in redirect


def test_rotation_publishes_both_keys_and_signs_with_the_new_one(provider: OidcProvider) -> None:
    before = _id_token(provider, OLGA, "before")
    old_kid = _kid(before)
    new_kid = provider.rotate_key()
    assert _published_kids(provider) == [new_kid, old_kid]
    after = _id_token(provider, OLGA, "after")
    assert _kid(after) == new_kid
    assert _verified_claims(provider, after)["nonce"] == "after"
    assert _verified_claims(provider, before)["nonce"] == "before"

    signed_out = requests.get(_discovery(provider)["end_session_endpoint"], allow_redirects=False, timeout=5,
                              params={"id_token_hint": before, "post_logout_redirect_uri": SIGNED_OUT_URI})
    assert signed_out.headers.get("Location") == SIGNED_OUT_URI, signed_out.text

    newest = provider.rotate_key()
    assert _published_kids(provider) == [newest, new_kid]
    keys = provider.signing_keys()
    assert jwk.JWK.from_pem(keys["active"].encode()).thumbprint() == newest
    assert [jwk.JWK.from_pem(pem.encode()).thumbprint() for pem in keys["inactive"]] == [new_kid]


def test_minted_tokens_verify_against_the_jwks_unless_signed_elsewhere(provider: OidcProvider) -> None:
    claims = {"iss": provider.issuer, "aud": CLIENT_ID, "sub": "1", "exp": int(time.time()) + 60}
    assert _verified_claims(provider, provider.mint_id_token(claims))["sub"] == "1"
    stranger = jwk.JWK.generate(kty="RSA", size=2048).export_to_pem(private_key=True, password=None).decode()
    forged = provider.mint_id_token(claims, key_pem=stranger, kid=_published_kids(provider)[0])
    with pytest.raises(jwt.JWTMissingKey):  # no published key verifies it
        _verified_claims(provider, forged)


def test_control_endpoints_want_the_token(provider: OidcProvider) -> None:
    assert requests.post(f"{provider.base_url}/test/rotate-key", timeout=5).status_code == 403
    assert requests.get(f"{provider.base_url}/test/keys", headers={"X-Test-Control": "guess"},
                        timeout=5).status_code == 403
