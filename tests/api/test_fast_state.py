"""The state API answered on the event loop for a token the process already trusts: the same answer
as the DRF view, no Django handler, and every other request still goes to Django."""

import asyncio
import json

import pytest
from channels.testing import HttpCommunicator
from rest_framework.authtoken.models import Token

from robot.api import fast_state
from robot.api.tokens import CachedTokenAuthentication
from tests.api.fastpaths import spy_on_passed_on

pytestmark = [pytest.mark.django_db(transaction=True), pytest.mark.usefixtures("empty_token_cache")]

PATH = "/api/robot/state/"


@pytest.fixture
def django_calls(monkeypatch):
    """Requests that reached Django's handler (the fast path's fallback)."""
    return spy_on_passed_on(monkeypatch, fast_state.FastStateApp, "django_app")


async def get(headers: dict[str, str], path: str = PATH) -> dict:
    from server.asgi import application

    raw = [(k.lower().encode(), v.encode()) for k, v in {"Host": "127.0.0.1", **headers}.items()]
    return await HttpCommunicator(application, "GET", path, headers=raw).get_response(timeout=10)


def token_for(user) -> dict[str, str]:
    return {"Authorization": f"Token {Token.objects.create(user=user).key}"}


def header_names(response: dict) -> set[bytes]:
    return {name.lower() for name, _ in response["headers"]}


async def test_a_trusted_token_is_answered_without_django_with_the_views_answer(viewer, django_calls):
    from asgiref.sync import sync_to_async

    headers = await sync_to_async(token_for)(viewer)
    first = await get(headers)  # not cached yet: Django checks the token and caches it
    second = await get(headers)
    assert django_calls == [PATH]
    assert first["status"] == second["status"] == 200
    assert json.loads(first["body"]).keys() == json.loads(second["body"]).keys()
    assert header_names(first) == header_names(second)
    assert dict(second["headers"])[b"Content-Type"] == b"application/json"
    assert dict(second["headers"])[b"X-Frame-Options"] == b"DENY"


async def test_a_trust_renewed_for_a_request_serves_it_however_soon_it_runs_out(viewer, monkeypatch, django_calls):
    from asgiref.sync import sync_to_async

    from robot.api import tokens

    headers = await sync_to_async(token_for)(viewer)
    await get(headers)  # Django checks the token and caches it
    await asyncio.sleep(tokens.TOKEN_CACHE_S + 0.1)  # the trust the first request gave has run out
    monkeypatch.setattr(tokens, "TOKEN_CACHE_S", 0.0)  # each renewal runs out at once: a loop stalled past it
    assert (await get(headers))["status"] == 200
    assert django_calls == [PATH]


async def test_a_deleted_token_is_refused_at_once_in_the_apis_error_shape(viewer, django_calls):
    from asgiref.sync import sync_to_async

    headers = await sync_to_async(token_for)(viewer)
    assert (await get(headers))["status"] == 200
    await sync_to_async(Token.objects.filter(user=viewer).delete)()
    response = await get(headers)
    assert response["status"] == 401 and json.loads(response["body"])["code"] == "authentication_failed"


@pytest.mark.parametrize("extra, path", [
    ({"Accept": "text/html"}, PATH),  # the browsable API
    ({}, PATH + "?format=json"),
    ({"Host": "evil.example"}, PATH),  # Django answers 400 for a host it does not serve
])
async def test_anything_but_a_plain_json_read_goes_to_django(viewer, django_calls, extra, path):
    from asgiref.sync import sync_to_async

    headers = await sync_to_async(token_for)(viewer)
    await get(headers)
    response = await get({**headers, **extra}, path)
    assert django_calls == [PATH, PATH]
    assert response["status"] in (200, 400)


async def test_an_unknown_token_goes_to_django_and_is_refused(django_calls):
    response = await get({"Authorization": "Token nope"})
    assert response["status"] == 401 and django_calls == [PATH]
    assert not CachedTokenAuthentication._cache


async def test_its_headers_are_the_ones_django_sends(viewer, django_calls):
    from asgiref.sync import sync_to_async

    headers = await sync_to_async(token_for)(viewer)
    through_django, fast = await get(headers), await get(headers)
    assert django_calls == [PATH]
    assert [name for name, _ in fast["headers"]] == [name for name, _ in through_django["headers"]]
    assert {k: v for k, v in fast["headers"] if k != b"Content-Length"} == \
        {k: v for k, v in through_django["headers"] if k != b"Content-Length"}
    assert dict(fast["headers"])[b"Content-Length"] == str(len(fast["body"])).encode()


async def test_a_host_no_longer_allowed_goes_to_django_again(viewer, django_calls, settings):
    from asgiref.sync import sync_to_async

    headers = await sync_to_async(token_for)(viewer)
    await get(headers)
    assert (await get(headers))["status"] == 200 and django_calls == [PATH]
    settings.ALLOWED_HOSTS = ["robot.example"]
    assert (await get(headers))["status"] == 400
    assert django_calls == [PATH, PATH]


async def test_hsts_follows_the_proxys_scheme_header(viewer, settings):
    from asgiref.sync import sync_to_async

    from server.asgi import django_asgi_app

    settings.SECURE_PROXY_SSL_HEADER = ("HTTP_X_FORWARDED_PROTO", "https")
    settings.SECURE_HSTS_SECONDS = 3600
    app = fast_state.FastStateApp(django_asgi_app)
    headers = await sync_to_async(token_for)(viewer)

    async def hsts(proto: str) -> bytes | None:
        raw = [(b"host", b"127.0.0.1"), (b"authorization", headers["Authorization"].encode()),
               (b"x-forwarded-proto", proto.encode())]
        response = await HttpCommunicator(app, "GET", PATH, headers=raw).get_response(timeout=10)
        assert response["status"] == 200
        return dict(response["headers"]).get(b"Strict-Transport-Security")

    await hsts("https")  # through Django (its middleware was built with the settings of its start): the token is new
    assert await hsts("https") == b"max-age=3600"
    assert await hsts("http") is None
    assert await hsts("https") == b"max-age=3600"


def _run_out(headers: dict[str, str]) -> None:
    """The process's trust in the token runs out (as it does TOKEN_CACHE_S after it was last asked)."""
    key = headers["Authorization"].removeprefix("Token ")
    _, user, token = CachedTokenAuthentication._cache[key]
    CachedTokenAuthentication._cache[key] = (0.0, user, token)


async def test_when_trust_runs_out_many_callers_stay_on_the_fast_path_behind_one_query(viewer, django_calls,
                                                                                     monkeypatch):
    from asgiref.sync import sync_to_async

    headers = await sync_to_async(token_for)(viewer)
    assert (await get(headers))["status"] == 200
    asked: list[str] = []
    real = CachedTokenAuthentication._renew

    def renew(key: str) -> object:
        asked.append(key)
        return real(key)

    monkeypatch.setattr(CachedTokenAuthentication, "_renew", classmethod(lambda cls, key: renew(key)))
    _run_out(headers)
    answers = await asyncio.gather(*(get(headers) for _ in range(20)))
    assert [a["status"] for a in answers] == [200] * 20
    assert django_calls == [PATH]  # only the very first request, which cached the token
    assert len(asked) == 1


async def test_a_renewal_sees_a_change_made_in_another_process(viewer, django_calls):
    from asgiref.sync import sync_to_async

    headers = await sync_to_async(token_for)(viewer)
    assert (await get(headers))["status"] == 200
    await sync_to_async(type(viewer).objects.filter(pk=viewer.pk).update)(is_active=False)  # no signal here
    assert (await get(headers))["status"] == 200  # still trusted, for at most TOKEN_CACHE_S
    _run_out(headers)
    response = await get(headers)
    assert response["status"] == 401 and json.loads(response["body"])["code"] == "authentication_failed"
    assert django_calls == [PATH, PATH]  # the refusal is Django's, in the API's error shape
