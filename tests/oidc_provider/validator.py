"""The test provider's OAuth2 validator: the ID token's extra claims come from the users in
``spec.json``, and a token is checked against whichever published key its ``kid`` names."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from django.conf import settings
from jwcrypto import jwk, jws
from oauth2_provider.oauth2_validators import OAuth2Validator
from oauth2_provider.settings import oauth2_settings
from oauth2_provider.utils import jwk_from_pem
from oauthlib.common import Request


def _profile(request: Request) -> dict[str, Any]:
    username = request.user.get_username()
    return next(user for user in settings.SPEC["users"] if user["username"] == username)


class ProviderValidator(OAuth2Validator):
    oidc_claim_scope = {**OAuth2Validator.oidc_claim_scope, "groups": "openid"}

    def get_additional_claims(self) -> dict[str, Callable[[Request], Any]]:
        return {
            "preferred_username": lambda request: request.user.get_username(),
            "name": lambda request: _profile(request)["name"],
            "email": lambda request: request.user.email,
            "email_verified": lambda request: _profile(request)["email_verified"],
            "groups": lambda request: list(_profile(request)["groups"]),
        }

    def _get_key_for_token(self, token: str) -> jwk.JWK | None:
        """DOT checks an ID token (say, a logout's ``id_token_hint``) with the active key only; a
        token signed before a rotation is still good while the JWKS publishes its key."""
        key = super()._get_key_for_token(token)
        if key is None:
            return None
        unverified = jws.JWS()
        unverified.deserialize(token)
        kid = unverified.jose_header.get("kid")
        for pem in [oauth2_settings.OIDC_RSA_PRIVATE_KEY, *oauth2_settings.OIDC_RSA_PRIVATE_KEYS_INACTIVE]:
            if jwk_from_pem(pem).thumbprint() == kid:
                return jwk_from_pem(pem)
        return key
