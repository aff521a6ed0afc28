"""The test provider's OAuth2 validator: the extra claims come from the users in ``spec.json``, in
the ID token or at the userinfo endpoint or as distributed claims as ``spec.json``'s ``claims_at``
says (set by a test, see ``urls.set_claims_at``), and a token is checked against whichever published
key its ``kid`` names."""

from __future__ import annotations

import hmac
from collections.abc import Callable
from typing import Any

from django.conf import settings
from jwcrypto import jwk, jws
from oauth2_provider.oauth2_validators import OAuth2Validator
from oauth2_provider.settings import oauth2_settings
from oauth2_provider.utils import jwk_from_pem
from oauthlib.common import Request

# Claims a provider may leave out of the ID token and answer only at its userinfo endpoint.
MOVABLE = ("email", "email_verified", "groups")
# Where Microsoft Entra ID points past 200 groups (no access token for it in the claims).
OVERAGE_ENDPOINT = "https://graph.microsoft.com/v1.0/users/00000000-0000-0000-0000-000000000000/getMemberObjects"


def _profile(request: Request) -> dict[str, Any]:
    username = request.user.get_username()
    return next(user for user in settings.SPEC["users"] if user["username"] == username)


def source_token(username: str) -> str:
    """The access token a distributed claim's source takes for ``username``'s claims."""
    return hmac.new(settings.SPEC["control_token"].encode(), username.encode(), "sha256").hexdigest()


def _groups_elsewhere(claims: dict[str, Any], username: str, *, pointer_only: bool) -> dict[str, Any]:
    endpoint = f"{settings.BASE_URL}/test/claims-source/{username}"
    source = {"endpoint": OVERAGE_ENDPOINT} if pointer_only else {"endpoint": endpoint,
                                                                   "access_token": source_token(username)}
    rest = {name: value for name, value in claims.items() if name != "groups"}
    return {**rest, "_claim_names": {"groups": "src1"}, "_claim_sources": {"src1": source}}


def placed(claims: dict[str, Any], username: str, *, in_id_token: bool) -> dict[str, Any]:
    """The claims of the ID token (``in_id_token``) or of the userinfo answer, where the test put them."""
    where = settings.SPEC.get("claims_at", "id_token")
    if where == "id_token":
        return claims
    if where in ("distributed", "pointer_only"):
        return _groups_elsewhere(claims, username, pointer_only=where == "pointer_only")
    if in_id_token:  # "userinfo", "userinfo_other_sub"
        return {name: value for name, value in claims.items() if name not in MOVABLE}
    return {**claims, "sub": "someone-else"} if where == "userinfo_other_sub" else claims


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

    def get_oidc_claims(self, token: Any, token_handler: Any, request: Request) -> dict[str, Any]:
        """The ID token's (DOT's userinfo answer comes through here too: see below)."""
        claims = super().get_oidc_claims(token, token_handler, request)
        return placed(claims, request.user.get_username(), in_id_token=True)

    def get_userinfo_claims(self, request: Request) -> dict[str, Any]:
        claims = super().get_oidc_claims(request.access_token, None, request)
        return placed(claims, request.user.get_username(), in_id_token=False)

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
