"""The account page: each person's own address for alerts (verified by a mailed link), their alert
choices, their API token, their password and their sessions; each form says how it went."""

from __future__ import annotations

import re
import time
from datetime import timedelta

import pytest
from django.core import mail, signing
from django.test import Client
from django.utils import timezone
from rest_framework import serializers
from rest_framework.authtoken.models import Token

from dashboard.models import SessionRecord
from dashboard.sessions import SEEN_EVERY, session_end, sessions_end_others, sessions_of
from robot.alerts.addresses import alert_address_forget, alert_address_request, alert_address_verify
from robot.alerts.choices import alert_choice_set
from robot.alerts.delivery import recipients
from robot.alerts.models import AlertChoice
from robot.api.tokens import TOKEN_CACHE_S, expires_at, token_create, token_revoke
from tests.api.token_cache import empty_token_cache  # noqa: F401
from tests.conftest import PASSWORD

pytestmark = [pytest.mark.django_db, pytest.mark.usefixtures("empty_token_cache")]


def _link(token: str) -> str:
    return f"http://testserver/account/email/verify/{token}/"


def _mailed_token() -> str:
    return re.search(r"/account/email/verify/([^/\s]+)/", mail.outbox[-1].body).group(1)


def _verified(user, address: str) -> None:
    alert_address_request(user=user, address=address, link=_link)
    alert_address_verify(user=user, token=_mailed_token())


def _signed_in(user) -> Client:
    """Logged in through the form, as a browser is (the login signal records the session)."""
    client = Client(HTTP_USER_AGENT="TestBrowser/1.0")
    res = client.post("/accounts/login/", {"username": user.username, "password": PASSWORD})
    assert res.status_code == 302, res.content
    return client


# The address for alerts

def test_it_mails_a_link_that_makes_the_address_the_persons_own(operator):
    alert_address_request(user=operator, address=" otto@example.org ", link=_link)
    assert mail.outbox[-1].to == ["otto@example.org"]
    assert not AlertChoice.objects.filter(user=operator).exclude(email="").exists()  # not before the link is opened
    assert alert_address_verify(user=operator, token=_mailed_token()) == "otto@example.org"
    assert AlertChoice.objects.get(user=operator).email == "otto@example.org"


def test_it_refuses_what_is_not_an_address_and_mails_nothing(operator):
    with pytest.raises(serializers.ValidationError, match="not an e-mail address"):
        alert_address_request(user=operator, address="otto at home", link=_link)
    assert mail.outbox == []


def test_a_link_counts_only_for_its_person_whole_and_while_the_address_it_replaces_is_still_theirs(operator, viewer):
    alert_address_request(user=operator, address="first@example.org", link=_link)
    first = _mailed_token()
    with pytest.raises(serializers.ValidationError, match="another account"):
        alert_address_verify(user=viewer, token=first)
    with pytest.raises(serializers.ValidationError, match="broken"):
        alert_address_verify(user=operator, token=first[:-2])
    _verified(operator, "second@example.org")
    with pytest.raises(serializers.ValidationError, match="changed since"):
        alert_address_verify(user=operator, token=first)
    assert AlertChoice.objects.get(user=operator).email == "second@example.org"


def test_an_old_link_has_expired(operator, monkeypatch):
    made = time.time() - 25 * 3600
    monkeypatch.setattr(signing.time, "time", lambda: made)
    alert_address_request(user=operator, address="otto@example.org", link=_link)
    monkeypatch.undo()
    with pytest.raises(serializers.ValidationError, match="expired"):
        alert_address_verify(user=operator, token=_mailed_token())


def test_alerts_by_email_go_to_the_verified_address_and_never_to_one_only_asked_for(operator):
    operator.email = "account@example.org"
    operator.save()
    alert_choice_set(operator, {"by_email": True, "kinds": ["estop"]})
    _verified(operator, "own@example.org")
    alert_address_request(user=operator, address="unconfirmed@example.org", link=_link)
    assert [t.address for t in recipients("estop", "critical") if t.channel == "email"] == ["own@example.org"]
    alert_address_forget(user=operator)
    assert [t.address for t in recipients("estop", "critical") if t.channel == "email"] == ["account@example.org"]


def test_a_verified_address_is_enough_to_choose_email_and_forgetting_it_stops_the_mail(operator):
    assert not operator.email
    with pytest.raises(serializers.ValidationError):
        alert_choice_set(operator, {"by_email": True, "kinds": ["estop"]})
    _verified(operator, "own@example.org")
    assert alert_choice_set(operator, {"by_email": True, "kinds": ["estop"]})["email"] == "own@example.org"
    alert_address_forget(user=operator)
    assert not AlertChoice.objects.get(user=operator).by_email
    assert recipients("estop", "critical") == []


def test_the_page_sends_the_link_and_the_link_confirms_with_a_notice(operator):
    client = _signed_in(operator)
    res = client.post("/account/email/", {"email": "otto@example.org"})
    assert res.status_code == 200 and b"We sent a link to otto@example.org" in res.content
    link = re.search(r"http://testserver(/account/email/verify/[^\s]+/)", mail.outbox[-1].body).group(1)
    res = client.get(link)
    assert res.status_code == 200 and b"Confirmed: alerts by e-mail go to otto@example.org" in res.content
    res = client.post("/account/email/", {"email": "nope"})
    assert res.status_code == 400 and b"not an e-mail address" in res.content


def test_the_page_saves_alert_choices_or_says_why_not(operator):
    client = _signed_in(operator)
    res = client.post("/account/alerts/", {"by_email": "on", "kinds": ["estop"], "min_severity": "error"})
    assert res.status_code == 400 and b"no e-mail address" in res.content
    res = client.post("/account/alerts/", {"by_push": "on", "kinds": ["estop", "log"], "min_severity": "error"})
    assert res.status_code == 200 and b"Your alert choices are saved" in res.content
    choice = AlertChoice.objects.get(user=operator)
    assert choice.by_push and not choice.by_email and choice.kinds == ["estop", "log"]
    assert choice.min_severity == "error"


# The API token

def test_a_token_made_here_ends_when_its_person_chose(client, operator, settings):
    settings.API_TOKEN_DAYS = 30
    token = token_create(user=operator, days=2)
    assert abs((expires_at(token) - timezone.now()) - timedelta(days=2)) < timedelta(minutes=1)
    assert client.get("/api/robot/state/", HTTP_AUTHORIZATION=f"Token {token.key}").status_code == 200
    token.expiry.expires = timezone.now() - timedelta(seconds=1)
    token.expiry.save()
    time.sleep(TOKEN_CACHE_S)
    assert client.get("/api/robot/state/", HTTP_AUTHORIZATION=f"Token {token.key}").status_code == 401


def test_a_new_token_takes_the_old_ones_place_and_lasts_no_longer_than_allowed(operator, settings):
    settings.API_TOKEN_DAYS = 30
    old = token_create(user=operator, days=1)
    new = token_create(user=operator, days=30)
    assert list(Token.objects.filter(user=operator)) == [new] and new.key != old.key
    for days in (0, -1, 31, float("nan")):
        with pytest.raises(serializers.ValidationError):
            token_create(user=operator, days=days)
    assert list(Token.objects.filter(user=operator)) == [new]


def test_a_revoked_token_gets_401(client, operator):
    token = token_create(user=operator, days=1)
    assert client.get("/api/robot/state/", HTTP_AUTHORIZATION=f"Token {token.key}").status_code == 200
    assert token_revoke(user=operator) is True
    assert token_revoke(user=operator) is False
    assert client.get("/api/robot/state/", HTTP_AUTHORIZATION=f"Token {token.key}").status_code == 401


def test_the_page_shows_a_new_token_once_and_revokes_it_with_a_notice(operator):
    client = _signed_in(operator)
    res = client.post("/account/token/", {"days": "7"})
    key = Token.objects.get(user=operator).key
    assert res.status_code == 200 and key.encode() in res.content and b"shown only this once" in res.content
    page = client.get("/account/")
    assert key.encode() not in page.content and b"You have a token" in page.content
    assert client.post("/account/token/", {"days": "many"}).status_code == 400
    res = client.post("/account/token/", {"revoke": "1"})
    assert res.status_code == 200 and b"revoked" in res.content and not Token.objects.filter(user=operator).exists()
    res = client.post("/account/token/", {"revoke": "1"})
    assert res.status_code == 400 and b"no API token" in res.content


# The password

def test_the_page_changes_the_password_and_ends_the_other_sessions_and_the_token(operator):
    here, elsewhere = _signed_in(operator), _signed_in(operator)
    token_create(user=operator, days=1)
    res = here.post("/account/password/", {"old_password": "wrong", "new_password1": "a whole new secret",
                                           "new_password2": "a whole new secret"})
    assert res.status_code == 400 and b"Password not changed" in res.content
    res = here.post("/account/password/", {"old_password": PASSWORD, "new_password1": "a whole new secret",
                                           "new_password2": "a whole new secret"})
    assert res.status_code == 200 and b"Your password is changed" in res.content
    assert here.get("/account/").status_code == 200
    assert elsewhere.get("/account/").status_code == 302
    assert not Token.objects.filter(user=operator).exists()
    assert [r.session_key for r in sessions_of(user=operator)] == [here.session.session_key]


def test_a_person_without_a_local_password_gets_no_password_form(operator):
    operator.set_unusable_password()
    operator.save()
    client = Client()
    client.force_login(operator)
    assert b"has no password here" in client.get("/account/").content
    assert b'name="old_password"' not in client.get("/account/").content
    res = client.post("/account/password/", {"old_password": "", "new_password1": "x", "new_password2": "x"})
    assert res.status_code == 400 and b"single sign-on" in res.content


# The sessions

def test_each_login_is_recorded_with_its_address_and_browser_and_a_logout_forgets_it(operator):
    first, second = _signed_in(operator), _signed_in(operator)
    records = sessions_of(user=operator)
    assert {r.session_key for r in records} == {first.session.session_key, second.session.session_key}
    assert all(r.user_agent == "TestBrowser/1.0" and r.address == "127.0.0.1" for r in records)
    second.post("/accounts/logout/")
    assert [r.session_key for r in sessions_of(user=operator)] == [first.session.session_key]


def test_ending_another_session_signs_it_out(operator, viewer):
    here, elsewhere = _signed_in(operator), _signed_in(operator)
    theirs = _signed_in(viewer)
    other = SessionRecord.objects.get(session_key=elsewhere.session.session_key)
    with pytest.raises(serializers.ValidationError, match="No such session"):
        session_end(user=viewer, record_id=other.pk, current_key=theirs.session.session_key)
    with pytest.raises(serializers.ValidationError, match="you are using"):
        session_end(user=operator, record_id=other.pk, current_key=elsewhere.session.session_key)
    res = here.post("/account/sessions/", {"session": other.pk})
    assert res.status_code == 200 and b"That session has ended" in res.content
    assert elsewhere.get("/account/").status_code == 302
    assert here.get("/account/").status_code == 200 and theirs.get("/account/").status_code == 200
    res = here.post("/account/sessions/", {"session": other.pk})
    assert res.status_code == 400 and b"No such session" in res.content


def test_ending_all_other_sessions_keeps_this_one_and_ends_unrecorded_ones_too(operator):
    here, recorded, unrecorded = _signed_in(operator), _signed_in(operator), _signed_in(operator)
    SessionRecord.objects.filter(session_key=unrecorded.session.session_key).delete()
    assert sessions_end_others(user=operator, current_key=here.session.session_key) == 2
    assert recorded.get("/account/").status_code == 302 and unrecorded.get("/account/").status_code == 302
    res = here.post("/account/sessions/", {"others": "1"})
    assert res.status_code == 200 and b"Ended 0 other sessions" in res.content


def test_a_session_is_seen_when_used_at_most_once_a_while(operator):
    client = _signed_in(operator)
    record = SessionRecord.objects.get(session_key=client.session.session_key)
    client.get("/account/")
    assert SessionRecord.objects.get(pk=record.pk).last_seen == record.last_seen  # seen at login, just now
    long_ago = timezone.now() - 2 * SEEN_EVERY
    SessionRecord.objects.filter(pk=record.pk).update(last_seen=long_ago)
    session = client.session
    session["_seen"] = long_ago.timestamp()
    session.save()
    client.get("/account/")
    seen = SessionRecord.objects.get(pk=record.pk).last_seen
    assert seen > long_ago + SEEN_EVERY
    client.get("/account/")
    assert SessionRecord.objects.get(pk=record.pk).last_seen == seen


def test_the_page_lists_the_sessions_and_marks_this_one(operator):
    client = _signed_in(operator)
    page = client.get("/account/").content.decode()
    assert "TestBrowser/1.0" in page and "this one" in page
    assert client.session.session_key not in page  # a session's key is its secret


def test_every_page_links_the_account_page_and_it_is_marked_where_one_is(operator):
    client = _signed_in(operator)
    assert b'href="/account/"' in client.get("/alerts/").content
    page = client.get("/account/").content.decode()
    assert re.search(r'<a href="/account/" aria-current="page">Account</a>', page)
    assert re.search(r'class="menu-current">Account<', page)
