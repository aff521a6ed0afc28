"""The account page in a real browser, at desktop and phone widths, against a real product whose
mail goes to a real SMTP server (aiosmtpd, into a maildir the test reads): a person confirms their
address for alerts by the mailed link, makes and revokes an API token (it then gets 401), ends their
other session (it is signed out) and changes their password; each form says how it went."""

from __future__ import annotations

import mailbox
import re
import subprocess
import sys
import urllib.error
import urllib.request
from email.message import Message
from pathlib import Path

import pytest
from playwright.sync_api import expect

from tests.browser.support import fresh_page, login
from tests.helpers import wait_until
from tests.stack import PASSWORD, Stack, free_port, wait_for_port

# A stack of its own (its mail goes to the test's SMTP server), started under the first test.
pytestmark = [pytest.mark.browser, pytest.mark.timeout(360)]

PERSON = {"desktop": "otto", "phone": "olga"}  # a person per width: the test changes their password
NEW_PASSWORD = "a whole new secret 42"


@pytest.fixture(scope="module")
def mail_stack(tmp_path_factory):
    port = free_port()
    box = tmp_path_factory.mktemp("mail") / "maildir"
    smtp = subprocess.Popen([sys.executable, "-m", "aiosmtpd", "-n", "-l", f"127.0.0.1:{port}",
                             "-c", "aiosmtpd.handlers.Mailbox", str(box)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for_port(port, proc=smtp)
        with Stack(sim=False, env={"EMAIL_HOST": "127.0.0.1", "EMAIL_PORT": str(port)}) as running:
            running.maildir = box
            yield running
    finally:
        smtp.terminate()
        smtp.wait(10)


def _mailed_link(box: Path, address: str) -> str | None:
    if not box.exists():
        return None
    for message in mailbox.Maildir(box, create=False):
        if message["To"] == address:
            body = message.get_payload(decode=True) if not message.is_multipart() else \
                next(part for part in message.walk() if isinstance(part, Message)
                     and part.get_content_type() == "text/plain").get_payload(decode=True)
            found = re.search(r"https?://\S+/account/email/verify/\S+/", body.decode())
            return found.group(0) if found else None
    return None


def _api_status(stack: Stack, key: str) -> int:
    request = urllib.request.Request(f"{stack.url}/api/me/theme/", headers={"Authorization": f"Token {key}"})
    try:
        with urllib.request.urlopen(request, timeout=10) as res:
            return res.status
    except urllib.error.HTTPError as exc:
        return exc.code


def _notice(page, text: str) -> None:
    notice = page.locator("#account-notice")
    expect(notice).to_contain_text(text)
    expect(notice).to_be_in_viewport()


def test_a_person_confirms_their_address_makes_and_revokes_a_token_ends_a_session_and_changes_their_password(
        sized_page, browser, mail_stack):
    page, person, url = sized_page, PERSON[sized_page.width_name], mail_stack.url
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    login(page, mail_stack, person)
    if page.width_name == "phone":
        page.click("#menu-btn")
    page.locator("nav.mainnav").get_by_role("link", name="Account").click()
    page.wait_for_url(f"{url}/account/")
    expect(page.locator(".menu-current")).to_have_text("Account")

    with fresh_page(browser) as elsewhere:
        login(elsewhere, mail_stack, person, next_path="/account/")
        page.reload()
        expect(page.locator("#account-sessions tr[data-session]")).to_have_count(2)

        address = f"{person}@example.org"
        page.fill("#account-email input[name=email]", "not an address@")
        # past the browser's own check, to the server's
        page.locator("#account-email input[name=email]").evaluate("el => el.type = 'text'")
        page.locator("#account-email button[type=submit]").click()
        expect(page.locator("#account-error")).to_contain_text("not an e-mail address")
        expect(page.locator("#account-error")).to_be_in_viewport()
        page.fill("#account-email input[name=email]", address)
        page.locator("#account-email button[type=submit]").click()
        _notice(page, f"We sent a link to {address}")
        link = wait_until(lambda: _mailed_link(mail_stack.maildir, address), timeout=20, what="the mailed link")
        page.goto(link)
        _notice(page, f"Confirmed: alerts by e-mail go to {address}")
        expect(page.locator('[data-field="alert-address"]')).to_have_text(address)

        page.locator("#account-alerts input[name=by_email]").check()
        page.locator('#account-alerts input[value="estop"]').check()
        page.locator("#account-alerts button[type=submit]").click()
        _notice(page, "Your alert choices are saved")
        expect(page.locator("#account-alerts input[name=by_email]")).to_be_checked()

        page.fill("#account-token input[name=days]", "7")
        page.locator("#account-token button.btn-primary").click()
        _notice(page, "shown only this once")
        key = page.input_value("#new-token")
        assert _api_status(mail_stack, key) == 200
        page.locator("#account-token button[name=revoke]").click()
        _notice(page, "Your API token is revoked")
        wait_until(lambda: _api_status(mail_stack, key) == 401, timeout=10, what="the revoked token refused")
        expect(page.locator("#new-token")).to_have_count(0)

        page.locator("#account-sessions tr[data-session]:not([data-current]) button").click()
        _notice(page, "That session has ended")
        expect(page.locator("#account-sessions tr[data-session]")).to_have_count(1)
        elsewhere.goto(f"{url}/account/")
        expect(elsewhere).to_have_url(re.compile(r"/accounts/login/"))

        page.fill("#account-password input[name=old_password]", PASSWORD)
        page.fill("#account-password input[name=new_password1]", NEW_PASSWORD)
        page.fill("#account-password input[name=new_password2]", NEW_PASSWORD)
        page.locator("#account-password button[type=submit]").click()
        _notice(page, "Your password is changed")
        page.goto(f"{url}/account/")
        expect(page).to_have_url(f"{url}/account/")  # this session stays signed in
        elsewhere.fill("input[name=username]", person)
        elsewhere.fill("input[name=password]", NEW_PASSWORD)
        elsewhere.click("button[type=submit]")
        elsewhere.wait_for_url(f"{url}/account/")

    assert page.evaluate("document.documentElement.scrollWidth <= document.documentElement.clientWidth")
    assert errors == []
