"""API tokens expire, die with a password change, and a change made elsewhere (another web process:
here, the cache filled before the change) reaches them within the cache's short period."""

from __future__ import annotations

import time
from datetime import timedelta

import pytest
from django.contrib.auth.models import Group
from django.test import Client
from rest_framework.authtoken.models import Token

from cyborg_site.roles import Role
from robot.api.tokens import TOKEN_CACHE_S, CachedTokenAuthentication
from tests.conftest import PASSWORD

pytestmark = pytest.mark.usefixtures("empty_token_cache")


def _token(client: Client, username: str) -> dict:
    res = client.post("/api/auth/token/", {"username": username, "password": PASSWORD},
                      content_type="application/json")
    assert res.status_code == 200, res.content
    return res.json()


def _get(client: Client, key: str, path: str = "/api/robot/state/") -> int:
    return client.get(path, HTTP_AUTHORIZATION=f"Token {key}").status_code


def test_a_token_says_when_it_expires_and_is_refused_after(client, operator, settings):
    settings.API_TOKEN_DAYS = 30
    got = _token(client, operator.username)
    assert got["expires"], got
    assert _get(client, got["token"]) == 200
    Token.objects.filter(key=got["token"]).update(created=Token.objects.get(key=got["token"]).created
                                                  - timedelta(days=31))
    time.sleep(TOKEN_CACHE_S)
    res = client.get("/api/robot/state/", HTTP_AUTHORIZATION=f"Token {got['token']}")
    assert res.status_code == 401
    assert "expired" in res.json()["detail"]
    assert not Token.objects.filter(key=got["token"]).exists()
    fresh = _token(client, operator.username)
    assert fresh["token"] != got["token"] and _get(client, fresh["token"]) == 200


def test_asking_again_after_expiry_gives_a_new_token(client, operator, settings):
    first = _token(client, operator.username)["token"]
    assert _token(client, operator.username)["token"] == first  # one token a person, while it lasts
    Token.objects.filter(key=first).update(created=Token.objects.get(key=first).created
                                           - timedelta(days=settings.API_TOKEN_DAYS + 1))
    assert _token(client, operator.username)["token"] != first


def test_tokens_that_never_expire_when_told(client, operator, settings):
    settings.API_TOKEN_DAYS = 0
    got = _token(client, operator.username)
    assert got["expires"] is None
    Token.objects.filter(key=got["token"]).update(created=Token.objects.get(key=got["token"]).created
                                                  - timedelta(days=3650))
    assert _get(client, got["token"]) == 200


def test_a_password_change_ends_the_persons_tokens(client, operator):
    key = _token(client, operator.username)["token"]
    assert _get(client, key) == 200
    operator.set_password("a whole new password")
    operator.save()
    assert not Token.objects.filter(user=operator).exists()
    assert _get(client, key) == 401


def test_other_saves_keep_the_token(client, operator):
    key = _token(client, operator.username)["token"]
    operator.first_name = "Otto"
    operator.save()
    assert _get(client, key) == 200


@pytest.mark.parametrize("change", ["deleted", "deactivated", "demoted"])
def test_a_change_made_elsewhere_reaches_a_cached_token_within_the_cache_period(client, operator, change):
    key = _token(client, operator.username)["token"]
    command = "/api/robot/speech/"
    assert _get(client, key) == 200  # cached now, as in every web process that served it
    entry = CachedTokenAuthentication._cache[key]
    if change == "deleted":
        Token.objects.filter(key=key).delete()
    elif change == "deactivated":
        operator.is_active = False
        operator.save()
    else:
        operator.groups.set([Group.objects.get(name=Role.VIEWER)])
    CachedTokenAuthentication._cache[key] = entry  # what another process still holds
    time.sleep(TOKEN_CACHE_S)
    res = client.post(command, {"text": "still here?"}, content_type="application/json",
                      HTTP_AUTHORIZATION=f"Token {key}")
    assert res.status_code == (403 if change == "demoted" else 401), res.content
