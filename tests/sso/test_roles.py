"""Roles from the provider's claims: the highest rule that matches, e-mail domains only when verified,
the default (or a refusal) for a person no rule matches; bad rules fail at start."""

from __future__ import annotations

import pytest

from cyborg_site.roles import Role
from dashboard.sso.config import SsoConfig, SsoConfigError, parse_rules
from dashboard.sso.roles import role_for


def config(rules: str, default: Role | None = None) -> SsoConfig:
    return SsoConfig(issuer="https://idp.example", client_id="c", client_secret="s", scopes="openid", name="Feide",
                     role_claim="groups", rules=parse_rules(rules), default_role=default, leeway_s=30)


RULES = "cyborg-admins=admin, cyborg-operators=operator cyborg-viewers=viewer @ntnu.no=viewer"


@pytest.mark.parametrize(("claims", "role"), [
    ({"groups": ["cyborg-operators"]}, Role.OPERATOR),
    ({"groups": ["cyborg-viewers", "cyborg-admins"]}, Role.ADMIN),
    ({"groups": "cyborg-operators"}, Role.OPERATOR),  # a provider sending one value as a string
    ({"groups": ["students"], "email": "kari@NTNU.no", "email_verified": True}, Role.VIEWER),
    ({"groups": ["students"], "email": "kari@ntnu.no", "email_verified": False}, None),
    ({"groups": ["students"], "email": "kari@ntnu.no"}, None),
    ({"groups": ["cyborg-operators-old"]}, None),
    ({"groups": {"cyborg-admins": True}}, None),  # not a list of names
    ({}, None),
])
def test_the_highest_matching_rule_gives_the_role(claims, role):
    assert role_for(claims, config(RULES)) == role


def test_a_person_no_rule_matches_gets_the_default_only_when_one_is_set():
    assert role_for({"groups": ["students"]}, config(RULES)) is None
    assert role_for({"groups": ["students"]}, config(RULES, default=Role.VIEWER)) == Role.VIEWER
    assert role_for({"groups": ["cyborg-operators"]}, config(RULES, default=Role.VIEWER)) == Role.OPERATOR


@pytest.mark.parametrize("bad", ["cyborg-admins", "cyborg-admins=root", "=viewer", "a=b=c"])
def test_a_bad_rule_is_refused_naming_it(bad):
    with pytest.raises(SsoConfigError, match="OIDC_ROLES"):
        parse_rules(bad)
