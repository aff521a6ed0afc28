"""Signing in through a real OpenID provider (the tests' own, a process of its own): the roles its
groups give, wherever it puts them (ID token, userinfo, distributed claims), refusals of people
without a role and of every broken or forged answer, rotated keys, a lockout that only forged
answers lead to, and logging out at both ends. The browser is Django's test client on this side and a
``requests`` session at the provider."""

from __future__ import annotations

import re
import urllib.parse

import pytest
import requests
from axes.models import AccessAttempt
from django.core.cache import cache
from django.test import Client

from cyborg_site.roles import Role, role_of
from robot.models import AuditEntry
from tests.conftest import PASSWORD
from tests.oidc_provider.harness import OidcProvider, ProviderUser

pytestmark = pytest.mark.django_db

SITE = "http://testserver"
ROLES = "cyborg-admins=admin cyborg-operators=operator cyborg-viewers=viewer"
USERS = [
    ProviderUser("kari", "kari-pw", groups=["cyborg-operators", "students"], email="kari@ntnu.no"),
    ProviderUser("vera", "vera-pw", groups=["cyborg-viewers"], email="vera@ntnu.no"),
    ProviderUser("nils", "nils-pw", groups=["students"], email="nils@ntnu.no"),
    *(ProviderUser(f"student{n}", f"student{n}-pw", groups=["students"], email=f"student{n}@ntnu.no")
      for n in range(10)),
]


@pytest.fixture(scope="module")
def provider():
    with OidcProvider(users=USERS, client_id="cyborg", client_secret="s3cret-of-the-client",
                      redirect_uris=[f"{SITE}/accounts/sso/callback/"],
                      post_logout_redirect_uris=[f"{SITE}/accounts/login/"]) as running:
        yield running


@pytest.fixture(autouse=True)
def sso(settings, provider):
    settings.OIDC_ISSUER = provider.issuer
    settings.OIDC_CLIENT_ID, settings.OIDC_CLIENT_SECRET = "cyborg", "s3cret-of-the-client"
    settings.OIDC_ROLES, settings.OIDC_NAME = ROLES, "Feide"
    cache.clear()  # refused identities are throttled there
    yield
    provider.claims_at("id_token")


class Person:
    """One browser: this site's cookies in ``site``, the provider's in ``at_provider``."""

    def __init__(self, provider: OidcProvider, username: str) -> None:
        self.provider = provider
        self.username = username
        self.site = Client()
        self.at_provider = requests.Session()

    def provider_login(self) -> None:
        login_url = f"{self.provider.base_url}/accounts/login/"
        form = self.at_provider.get(login_url, timeout=10).text
        csrf = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', form)
        assert csrf, form
        password = next(user.password for user in USERS if user.username == self.username)
        answer = self.at_provider.post(login_url, allow_redirects=False, timeout=10, headers={"Referer": login_url},
                                       data={"csrfmiddlewaretoken": csrf[1], "username": self.username,
                                             "password": password})
        assert answer.status_code == 302, answer.text

    def to_provider(self, next_path: str = "") -> str:
        """Press "Sign in with Feide": the provider's authorisation URL this site sends the browser to."""
        answer = self.site.get("/accounts/sso/login/" + (f"?next={next_path}" if next_path else ""))
        assert answer.status_code == 302
        return answer["Location"]

    def at_the_provider(self, authorize_url: str) -> str:
        """Follow the provider until it sends the browser back here: that callback URL (path and query)."""
        url = authorize_url
        for _ in range(5):
            answer = self.at_provider.get(url, allow_redirects=False, timeout=10)
            assert answer.status_code == 302, answer.text
            url = urllib.parse.urljoin(url, answer.headers["Location"])
            if url.startswith(SITE):
                return url.removeprefix(SITE)
            if "/accounts/login/" in url:
                self.provider_login()
                url = authorize_url
        raise AssertionError(f"the provider never sent the browser back (last: {url})")

    def sign_in(self, next_path: str = ""):
        return self.site.get(self.at_the_provider(self.to_provider(next_path)))


def _last_sso_audit() -> AuditEntry:
    return AuditEntry.objects.filter(action="login.sso").latest("id")


def test_the_authorisation_request_carries_state_nonce_and_a_pkce_challenge(provider):
    query = urllib.parse.parse_qs(urllib.parse.urlsplit(Person(provider, "kari").to_provider()).query)
    assert query["response_type"] == ["code"] and query["client_id"] == ["cyborg"]
    assert query["code_challenge_method"] == ["S256"] and len(query["code_challenge"][0]) >= 43
    assert len(query["state"][0]) >= 20 and len(query["nonce"][0]) >= 20
    assert query["scope"] == ["openid profile email"]


def test_an_operator_signs_in_and_may_command(provider):
    kari = Person(provider, "kari")
    answer = kari.sign_in(next_path="/map/")
    assert (answer.status_code, answer["Location"]) == (302, "/map/")
    user = kari.site.get("/").wsgi_request.user
    assert (user.username, user.email, role_of(user)) == ("kari", "kari@ntnu.no", Role.OPERATOR)
    entry = _last_sso_audit()
    assert (entry.ok, entry.username, entry.outcome) == (True, "kari", "signed in as operator")
    assert entry.params["issuer"] == provider.issuer
    speech = kari.site.post("/api/robot/speech/", {"text": "hello"}, content_type="application/json")
    assert speech.status_code != 403  # past the role check (the robot itself is not running here)


def test_a_viewer_signs_in_and_is_refused_commands(provider):
    vera = Person(provider, "vera")
    assert vera.sign_in().status_code == 302
    assert vera.site.get("/").status_code == 200
    speech = vera.site.post("/api/robot/speech/", {"text": "hello"}, content_type="application/json")
    assert speech.status_code == 403


def test_a_person_in_no_mapped_group_is_refused_with_a_page_and_an_audit_row(provider):
    nils = Person(provider, "nils")
    answer = nils.sign_in()
    assert answer.status_code == 403
    assert "is not in a group that may use the Cyborg" in answer.content.decode()
    assert nils.site.get("/").status_code == 302  # not logged in
    entry = _last_sso_audit()
    assert (entry.ok, entry.error_code, entry.params["username"]) == (False, "no_role", "nils")


def test_the_role_follows_the_groups_at_every_login(provider):
    kari = Person(provider, "kari")
    assert kari.sign_in().status_code == 302
    provider.set_groups("kari", ["cyborg-viewers"])
    try:
        again = Person(provider, "kari")
        assert again.sign_in().status_code == 302
        assert role_of(again.site.get("/").wsgi_request.user) == Role.VIEWER
        provider.set_groups("kari", [])
        assert Person(provider, "kari").sign_in().status_code == 403
    finally:
        provider.set_groups("kari", ["cyborg-operators", "students"])


def test_a_replayed_callback_is_refused(provider):
    kari = Person(provider, "kari")
    callback = kari.at_the_provider(kari.to_provider())
    assert kari.site.get(callback).status_code == 302
    kari.site.logout()
    replayed = kari.site.get(callback)  # the state was used up
    assert replayed.status_code == 403 and "could not be verified" in replayed.content.decode()
    elsewhere = Client().get(callback)  # another browser, which never started this sign-in
    assert elsewhere.status_code == 403
    assert _last_sso_audit().error_code == "not_verified"


@pytest.mark.parametrize(("mischief", "why"), [
    ("tampered", "bad_signature"), ("wrong_audience", "Invalid claim: 'aud'"), ("wrong_issuer", "Invalid claim: 'iss'"),
    ("expired", "expired"), ("wrong_nonce", "nonce"), ("unknown_key", "No key for kid"), ("no_id_token", "no ID token"),
])
def test_a_broken_or_forged_id_token_is_refused(provider, mischief, why):
    kari = Person(provider, "kari")
    callback = kari.at_the_provider(kari.to_provider())
    provider.misbehave(mischief)
    answer = kari.site.get(callback)
    assert answer.status_code == 403, mischief
    assert "could not be verified" in answer.content.decode()
    assert kari.site.get("/").status_code == 302
    entry = _last_sso_audit()
    assert entry.error_code == "not_verified" and why in entry.outcome


def test_a_rotated_signing_key_is_picked_up(provider):
    assert Person(provider, "kari").sign_in().status_code == 302  # the old key is known by now
    provider.rotate_key()
    assert Person(provider, "kari").sign_in().status_code == 302
    provider.rotate_key()  # and again: the first key is gone from the provider's keys
    assert Person(provider, "vera").sign_in().status_code == 302


def test_a_locked_out_address_is_refused_here_too(provider, settings):
    """(django-axes answers, as on the login form.)"""
    for _ in range(settings.AXES_FAILURE_LIMIT):
        Client().post("/accounts/login/", {"username": "someone", "password": "wrong"})
    kari = Person(provider, "kari")
    answer = kari.sign_in()
    assert answer.status_code == 429 and "Too many failed logins" in answer.content.decode()
    assert kari.site.get("/").status_code == 302
    assert _last_sso_audit().error_code == "locked_out"


def test_logging_out_ends_the_providers_session_too(provider):
    kari = Person(provider, "kari")
    assert kari.sign_in().status_code == 302
    answer = kari.site.post("/accounts/logout/")
    end_session = answer["Location"]
    assert end_session.startswith(f"{provider.issuer}/logout/") and "id_token_hint=" in end_session
    assert kari.site.get("/").status_code == 302
    back = kari.at_provider.get(end_session, allow_redirects=False, timeout=10)
    assert back.status_code == 302 and back.headers["Location"].startswith(f"{SITE}/accounts/login/")
    # Signing in again asks for the password at the provider: its session ended too.
    again = kari.at_provider.get(kari.to_provider(), allow_redirects=False, timeout=10)
    assert "/accounts/login/" in again.headers["Location"]


def _signed_in_as(person: Person) -> tuple[str, str, Role | None]:
    user = person.site.get("/").wsgi_request.user
    if not user.is_authenticated:
        return "", "", None
    return user.username, user.email, role_of(user)


@pytest.mark.parametrize("where", ["id_token", "userinfo", "distributed"])
def test_the_groups_and_e_mail_are_read_wherever_the_provider_puts_them(provider, where):
    provider.claims_at(where)
    kari = Person(provider, "kari")
    assert kari.sign_in().status_code == 302, where
    assert _signed_in_as(kari) == ("kari", "kari@ntnu.no", Role.OPERATOR)
    assert _last_sso_audit().outcome == "signed in as operator"


def test_a_userinfo_answer_for_another_subject_is_refused_and_counts_as_forged(provider):
    provider.claims_at("userinfo_other_sub")
    kari = Person(provider, "kari")
    answer = kari.sign_in()
    assert answer.status_code == 403
    assert "userinfo answer is for another subject" in answer.content.decode()
    assert _signed_in_as(kari)[2] is None
    entry = _last_sso_audit()
    assert entry.error_code == "claims_refused" and "another subject" in entry.outcome
    assert AccessAttempt.objects.filter(ip_address="127.0.0.1").exists()


def test_groups_only_pointed_at_without_a_token_are_refused_with_the_reason(provider):
    """(Microsoft Entra ID past 200 groups.) Not the address's fault: it does not count toward its lockout."""
    provider.claims_at("pointer_only")
    kari = Person(provider, "kari")
    answer = kari.sign_in()
    assert answer.status_code == 403
    page = answer.content.decode()
    assert "only as a link" in page and "Entra ID does past 200 groups" in page
    assert _last_sso_audit().error_code == "claims_refused"
    assert not AccessAttempt.objects.exists()


def test_a_role_claim_the_provider_never_sends_is_named_in_the_audit_and_on_the_page(provider, settings):
    settings.OIDC_ROLE_CLAIM = "roles"  # this provider sends "groups" only
    refused = Person(provider, "kari").sign_in()
    assert refused.status_code == 403
    assert "Feide sent no &#x27;roles&#x27; claim" in refused.content.decode()
    assert "sent no 'roles' claim" in _last_sso_audit().outcome
    settings.OIDC_DEFAULT_ROLE = "viewer"
    kari = Person(provider, "kari")
    assert kari.sign_in().status_code == 302
    entry = _last_sso_audit()
    assert entry.ok and entry.outcome.startswith("signed in as viewer, the default role: Feide sent no 'roles' claim")
    page = kari.site.get("/")
    assert role_of(page.wsgi_request.user) == Role.VIEWER
    notice = "You are signed in as viewer, the default role: Feide sent no &#x27;roles&#x27; claim"
    assert notice in page.content.decode()


def test_people_in_no_mapped_group_do_not_lock_out_their_address(provider, settings, admin_user):
    """Ten students behind one campus address: each refused and audited, none counted against the
    address; the operators and the break-glass admin still get in from there."""
    for n in range(10):
        answer = Person(provider, f"student{n}").sign_in()
        assert answer.status_code == 403, n
        assert "is not in a group that may use the Cyborg" in answer.content.decode()
    assert AuditEntry.objects.filter(action="login.sso", error_code="no_role").count() == 10
    kari = Person(provider, "kari")
    assert kari.sign_in().status_code == 302
    assert _signed_in_as(kari)[2] == Role.OPERATOR
    speech = kari.site.post("/api/robot/speech/", {"text": "hello"}, content_type="application/json")
    assert speech.status_code not in (401, 403, 429)  # past the role check (the E-STOP: tests/browser/test_sso.py)
    token = Client().post("/api/auth/token/", {"username": admin_user.username, "password": PASSWORD},
                          content_type="application/json")
    assert token.status_code == 200, token.content


def test_one_person_refused_again_and_again_is_throttled_not_their_address(provider, settings):
    for _ in range(settings.AXES_FAILURE_LIMIT):
        assert Person(provider, "nils").sign_in().status_code == 403
    again = Person(provider, "nils").sign_in()
    assert again.status_code == 429 and "refused here too often" in again.content.decode()
    assert _last_sso_audit().error_code == "throttled"
    assert Person(provider, "vera").sign_in().status_code == 302


def test_forged_answers_still_lock_out_the_address(provider, settings):
    for _ in range(settings.AXES_FAILURE_LIMIT):
        kari = Person(provider, "kari")
        callback = kari.at_the_provider(kari.to_provider())
        provider.misbehave("tampered")
        assert kari.site.get(callback).status_code in (403, 429)  # 429: the one that locks the address
    answer = Person(provider, "vera").sign_in()
    assert answer.status_code == 429 and "Too many failed logins" in answer.content.decode()
