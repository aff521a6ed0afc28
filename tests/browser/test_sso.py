"""Single sign-on in a real browser against the tests' own OpenID provider (a process of its own):
an operator signs in and drives, a viewer signs in and is refused commands, a person in no mapped
group is refused (ten of them from one address do not lock the operators out of it), a signed-in
session gets its own API token, and a rotated signing key is survived."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.browser.support import fresh_page
from tests.oidc_provider.harness import OidcProvider, ProviderUser
from tests.stack import Stack

pytestmark = pytest.mark.browser

USERS = [
    ProviderUser("kari", "kari-pw", groups=["cyborg-operators"], email="kari@ntnu.no"),
    ProviderUser("vera", "vera-pw", groups=["cyborg-viewers"], email="vera@ntnu.no"),
    ProviderUser("nils", "nils-pw", groups=["students"], email="nils@ntnu.no"),
    *(ProviderUser(f"student{n}", f"student{n}-pw", groups=["students"]) for n in range(10)),
]


@pytest.fixture(scope="module")
def sso_stack():
    stack = Stack()
    with OidcProvider(users=USERS, client_id="cyborg", client_secret="s3cret-of-the-client",
                      redirect_uris=[f"{stack.url}/accounts/sso/callback/"],
                      post_logout_redirect_uris=[f"{stack.url}/accounts/login/"]) as provider:
        stack.env.update(OIDC_ISSUER=provider.issuer, OIDC_CLIENT_ID="cyborg", OIDC_NAME="Feide",
                         OIDC_CLIENT_SECRET="s3cret-of-the-client",
                         OIDC_ROLES="cyborg-operators=operator cyborg-viewers=viewer")
        with stack:
            stack.wait_robot_online()
            yield stack, provider


def sign_in(page, stack: Stack, username: str, *, next_path: str = "/") -> None:
    page.goto(f"{stack.url}/accounts/login/?next={next_path}")
    page.get_by_role("link", name="Sign in with Feide").click()
    page.fill("input[name=username]", username)
    page.fill("input[name=password]", next(user.password for user in USERS if user.username == username))
    page.get_by_role("button", name="Sign in").click()


def refused(page, stack: Stack, why: str) -> None:
    """The refusal page says why, and the person is not logged in."""
    expect(page.get_by_role("alert")).to_contain_text(why)
    page.goto(f"{stack.url}/")
    page.wait_for_url(f"{stack.url}/accounts/login/?next=/")


def test_an_operator_signs_in_and_drives(browser, sso_stack):
    stack, _ = sso_stack
    with fresh_page(browser) as page:
        sign_in(page, stack, "kari", next_path="/drive/")
        page.wait_for_url(f"{stack.url}/drive/")
        page.locator("#drive h2").click()  # the page has the keyboard
        page.keyboard.down("w")
        expect(page.locator("#lock-state")).to_have_text("You are driving")
        expect(page.locator("#cmd-vel")).not_to_have_attribute("data-linear", "0")
        page.keyboard.up("w")
        expect(page.locator("#cmd-vel")).to_have_attribute("data-linear", "0")


def test_a_viewer_signs_in_and_is_refused_commands(browser, sso_stack):
    stack, _ = sso_stack
    with fresh_page(browser) as page:
        sign_in(page, stack, "vera")
        page.wait_for_url(f"{stack.url}/")
        token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
        answer = page.request.post(f"{stack.url}/api/robot/speech/", data={"text": "hello"},
                                   headers={"X-CSRFToken": token})
        assert answer.status == 403, answer.text()
        page.goto(f"{stack.url}/drive/")
        expect(page.locator("#lock-state")).not_to_have_text("You are driving")


def test_a_person_in_no_mapped_group_is_refused(browser, sso_stack):
    stack, _ = sso_stack
    with fresh_page(browser) as page:
        sign_in(page, stack, "nils")
        refused(page, stack, "is not in a group that may use the Cyborg")


def _post(page, stack: Stack, path: str, body: dict | None = None):
    token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
    return page.request.post(f"{stack.url}{path}", data=body or {}, headers={"X-CSRFToken": token})


def test_students_in_no_group_do_not_lock_their_address_out_and_an_operator_stops_the_robot(browser, sso_stack):
    """Ten people in no mapped group sign in from one address (a campus NAT: here 127.0.0.1); each is
    refused, none counts against the address: an operator from there signs in and presses the E-STOP."""
    stack, _ = sso_stack
    for n in range(10):
        with fresh_page(browser) as page:
            sign_in(page, stack, f"student{n}")
            refused(page, stack, "is not in a group that may use the Cyborg")
    with fresh_page(browser) as page:
        sign_in(page, stack, "kari")
        page.wait_for_url(f"{stack.url}/")
        try:
            page.locator("#estop-btn").click()
            expect(page.locator("#estop-banner")).to_be_visible()
            assert page.request.get(f"{stack.url}/api/robot/estop/").json()["latched"]
        finally:
            assert _post(page, stack, "/api/robot/estop/release/", {"confirm": True}).ok
            assert _post(page, stack, "/api/robot/motors/", {"enabled": True}).ok
        # A person who signs in here gets an API token from the session (no password to give).
        got = _post(page, stack, "/api/auth/token/")
        assert got.ok, got.text()
        key = got.json()["token"]
        state = page.request.get(f"{stack.url}/api/robot/state/", headers={"Authorization": f"Token {key}"})
        assert state.ok, state.text()


def test_a_rotated_signing_key_is_survived_and_logout_ends_both_sessions(browser, sso_stack):
    stack, provider = sso_stack
    with fresh_page(browser) as page:
        sign_in(page, stack, "kari")
        page.wait_for_url(f"{stack.url}/")
        provider.rotate_key()
        page.context.clear_cookies()
        sign_in(page, stack, "kari")
        page.wait_for_url(f"{stack.url}/")
        page.get_by_role("button", name="Log out").click()
        page.wait_for_url(f"{stack.url}/accounts/login/**")
        page.get_by_role("link", name="Sign in with Feide").click()
        expect(page.locator("input[name=password]")).to_be_visible()  # the provider asks again


@pytest.mark.parametrize("mischief", ["tampered", "wrong_audience", "expired"])
def test_a_broken_id_token_is_refused(browser, sso_stack, mischief):
    stack, provider = sso_stack
    with fresh_page(browser) as page:
        provider.misbehave(mischief)
        sign_in(page, stack, "kari")
        refused(page, stack, "could not be verified")


def test_a_replayed_callback_is_refused(browser, sso_stack):
    stack, _ = sso_stack
    with fresh_page(browser) as page:
        callbacks: list[str] = []
        page.on("request", lambda request: callbacks.append(request.url) if "/sso/callback/" in request.url else None)
        sign_in(page, stack, "kari")
        page.wait_for_url(f"{stack.url}/")
        page.get_by_role("button", name="Log out").click()
        page.wait_for_url(f"{stack.url}/accounts/login/**")
        page.goto(callbacks[0])
        refused(page, stack, "could not be verified")
