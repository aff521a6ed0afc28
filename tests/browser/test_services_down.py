"""A page open while the database goes away (a private PostgreSQL, stopped for real) says so, and
that the E-STOP still works, and stops saying it when the database is back."""

from __future__ import annotations

import re

import pytest
from playwright.sync_api import expect

from tests.browser.support import login
from tests.support_processes import online_on_private_postgres

pytestmark = pytest.mark.browser


@pytest.fixture
def on_private_postgres():
    with online_on_private_postgres() as running:
        yield running


def test_an_open_page_says_the_database_is_down_and_that_the_estop_still_works(browser, on_private_postgres):
    stack = on_private_postgres
    context = browser.new_context()
    try:
        page = context.new_page()
        login(page, stack, "otto", next_path="/drive/")
        strip = page.locator("#services-strip")
        expect(page.locator("#link-pill")).to_have_text("robot online", timeout=15_000)
        expect(strip).to_be_hidden()
        stack.postgres.stop()
        expect(strip).to_be_visible(timeout=10_000)
        expect(strip).to_have_text(re.compile(r"The database is unreachable.*The E-STOP still works\."))
        stack.postgres.start()
        expect(strip).to_be_hidden(timeout=15_000)
    finally:
        context.close()
