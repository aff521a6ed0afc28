"""The read path without needless work: token lookups cached briefly."""

import pytest
from rest_framework.authtoken.models import Token

from robot.api.tokens import CachedTokenAuthentication

pytestmark = [pytest.mark.django_db, pytest.mark.usefixtures("empty_token_cache")]


def test_a_known_token_costs_no_query_after_the_first_request(client, viewer, django_assert_num_queries):
    headers = {"Authorization": f"Token {Token.objects.create(user=viewer).key}"}
    assert client.get("/api/robot/state/", headers=headers).status_code == 200
    with django_assert_num_queries(0):
        response = client.get("/api/robot/state/", headers=headers)
    assert response.status_code == 200 and "connected" in response.json()


def test_a_deleted_token_is_refused_at_once(client, viewer):
    token = Token.objects.create(user=viewer)
    headers = {"Authorization": f"Token {token.key}"}
    assert client.get("/api/robot/state/", headers=headers).status_code == 200
    token.delete()
    response = client.get("/api/robot/state/", headers=headers)
    assert response.status_code == 401 and response.json()["code"]


def test_an_unknown_token_is_refused_and_not_cached(client):
    response = client.get("/api/robot/state/", headers={"Authorization": "Token nope"})
    assert response.status_code == 401
    assert not CachedTokenAuthentication._cache
