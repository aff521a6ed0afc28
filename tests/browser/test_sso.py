"""Single sign-on in a real browser against the tests' own OpenID provider (a process of its own):
an operator signs in and drives, a viewer signs in and is refused commands, a person in no mapped
group is refused, and a rotated signing key is survived."""

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
