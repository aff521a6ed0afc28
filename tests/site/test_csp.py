"""Every page carries the Content-Security-Policy, and none holds what it would block: an inline
script (data in json_script blocks is not run), an event-handler attribute, a style attribute or
element. tests/browser/test_csp.py runs the same pages in Chromium."""

from __future__ import annotations

import re

import pytest
from django.test import Client

from cyborg_site.csp import HEADER, POLICY, policy_header

pytestmark = pytest.mark.django_db

EXPECTED = ("default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; "
            "connect-src 'self'; object-src 'none'; base-uri 'self'; frame-ancestors 'none'; form-action 'self'")
OURS = ["/", "/map/", "/drive/", "/topics/", "/diagnostics/", "/history/", "/activity/"]
THEIRS = ["/admin/", "/admin/auth/user/", "/admin/robot/location/add/", "/admin/history/topicpolicy/",
          "/api/docs/", "/api/robot/state/", "/api/locations/", "/api/audit/", "/no/such/page/"]
INLINE_SCRIPT = re.compile(r"<script\b(?![^>]*\bsrc=)(?![^>]*type=\"application/json\")[^>]*>", re.I)
HANDLER_OR_STYLE = re.compile(r"<[a-z][^>]*\s(on[a-z]+|style)\s*=|<style\b", re.I)


@pytest.fixture
def ada(admin_user) -> Client:
    client = Client()
    client.force_login(admin_user)
    return client


def page(client: Client, path: str):
    response = client.get(path, headers={"accept": "text/html"})
    assert response.status_code in (200, 404), (path, response.status_code)
    return response


def test_the_policy_is_the_sites_own_sources_only():
    assert policy_header() == EXPECTED
    assert set(POLICY) >= {"default-src", "object-src", "frame-ancestors", "form-action", "base-uri"}


@pytest.mark.parametrize("path", [*OURS, *THEIRS])
def test_every_page_carries_the_policy_and_holds_nothing_it_blocks(ada, path):
    response = page(ada, path)
    assert response[HEADER] == EXPECTED
    html = response.content.decode()
    assert INLINE_SCRIPT.findall(html) == [], path
    assert HANDLER_OR_STYLE.findall(html) == [], path


def test_the_login_page_carries_it_too(client):
    response = page(client, "/accounts/login/")
    assert response[HEADER] == EXPECTED and not INLINE_SCRIPT.findall(response.content.decode())


def test_only_the_state_machine_page_may_compile_webassembly(ada):
    response = page(ada, "/statemachine/")
    assert response[HEADER] == EXPECTED.replace("script-src 'self'", "script-src 'self' 'wasm-unsafe-eval'")
    assert "wasm" not in page(ada, "/").get(HEADER)


def test_the_api_docs_start_up_script_is_a_file_of_its_own(ada):
    html = page(ada, "/api/docs/").content.decode()
    assert '<script src="/api/docs/?script=">' in html
    script = ada.get("/api/docs/?script=")
    assert script.status_code == 200 and script["Content-Type"].startswith("application/javascript")
    assert "SwaggerUIBundle" in script.content.decode()
