"""A person's claims from wherever the provider puts them: the ID token's, merged with the userinfo
endpoint's when a wanted claim is not in the ID token (the same ``sub`` required, OpenID Connect
Core 5.3.2), and distributed or aggregated claims (5.6.2) taken from their source."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from dashboard.sso.config import SsoConfig

NAMES, SOURCES = "_claim_names", "_claim_sources"


class ClaimsRefused(Exception):
    """The claims cannot be completed; ``forged``: the provider's answer itself is wrong (it counts
    toward the address's lockout, as a bad signature does)."""

    def __init__(self, reason: str, *, forged: bool = False) -> None:
        super().__init__(reason)
        self.reason = reason
        self.forged = forged


def wanted(config: SsoConfig) -> tuple[str, ...]:
    """The claims a sign-in reads: the role claim and the e-mail."""
    return (config.role_claim, "email")


def missing(claims: Mapping[str, Any], config: SsoConfig) -> list[str]:
    """The wanted claims neither given nor pointed at (distributed or aggregated)."""
    pointed = claims.get(NAMES)
    pointed = pointed if isinstance(pointed, Mapping) else {}
    return [name for name in wanted(config) if name not in claims and name not in pointed]


def merged_with_userinfo(id_claims: Mapping[str, Any], userinfo: Mapping[str, Any]) -> dict[str, Any]:
    """The userinfo answer's claims beside the ID token's (which stand where both have one)."""
    if str(userinfo.get("sub", "")) != str(id_claims.get("sub", "")):
        raise ClaimsRefused("the provider's userinfo answer is for another subject than the ID token", forged=True)
    return {**userinfo, **id_claims}


def resolved(claims: Mapping[str, Any], config: SsoConfig, *, verified: Callable[[str], dict[str, Any]],
             fetched: Callable[[str, str], str]) -> dict[str, Any]:
    """``claims`` with the wanted ones that are only pointed at taken from their sources: a JWT in the
    claims (aggregated) or fetched from an endpoint with the access token given for it (distributed),
    either checked by ``verified`` (the provider's keys). ``fetched(endpoint, access_token)`` is the
    source's answer. ``ClaimsRefused`` says why a claim could not be had."""
    names, sources = claims.get(NAMES), claims.get(SOURCES)
    plain = {name: value for name, value in claims.items() if name not in (NAMES, SOURCES)}
    if not isinstance(names, Mapping):
        return plain
    sources = sources if isinstance(sources, Mapping) else {}
    for name in wanted(config):
        if name in plain or name not in names:
            continue
        source = sources.get(names[name])
        if not isinstance(source, Mapping):
            raise ClaimsRefused(f"the provider points the '{name}' claim at a source it does not describe")
        if "JWT" in source:
            given = verified(str(source["JWT"]))
        elif source.get("endpoint") and source.get("access_token"):
            given = verified(fetched(str(source["endpoint"]), str(source["access_token"])))
        else:
            raise ClaimsRefused(
                f"the provider sent the '{name}' claim only as a link ({source.get('endpoint', 'none')}) with no "
                f"access token to fetch it with, as Microsoft Entra ID does past 200 groups; have it send "
                f"'{name}' itself (for example only the groups assigned to this application)")
        if "sub" in given and str(given["sub"]) != str(claims.get("sub", "")):
            raise ClaimsRefused(f"the source of the '{name}' claim answered for another subject", forged=True)
        if name not in given:
            raise ClaimsRefused(f"the source of the '{name}' claim did not give it")
        plain[name] = given[name]
    return plain
