"""A real product (simulator + Daphne processes) and a real headless Chromium, shared per session.

The fixtures are registered in tests/conftest.py so every folder shares one stack and browser."""

from __future__ import annotations

import contextlib
import os
import shutil

import pytest

from tests.stack import PASSWORD, Stack

# Debian's headless shell: Chromium's engine without its browser UI, which in a headless Chromium still
# runs a renderer of its own per window (a third of a core while a test's page is open).
CHROMIUM = (os.environ.get("CHROMIUM_PATH") or shutil.which("chromium-headless-shell") or shutil.which("chromium")
            or "/usr/bin/chromium-headless-shell")
CHROMIUM_ARGS = [
    "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--disable-dev-shm-usage",
]
# Permission prompts belong to the browser UI: a test of a denied prompt needs the whole Chromium.
FULL_CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
FULL_CHROMIUM_ARGS = ["--headless=new", *CHROMIUM_ARGS]


@pytest.fixture(scope="session")
def stack():
    with Stack() as running:
        running.wait_robot_online()
        yield running


@pytest.fixture(scope="session")
def browser():
    from playwright.sync_api import sync_playwright

    if not os.path.exists(CHROMIUM):
        pytest.fail(f"Chromium not found at {CHROMIUM}: run `make browser` (Debian package chromium)")
    with sync_playwright() as p:
        instance = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield instance
        instance.close()


DESKTOP = {"width": 1366, "height": 800}
PHONE = {"width": 390, "height": 844}
WIDTHS = {"desktop": DESKTOP, "phone": PHONE}


@contextlib.contextmanager
def fresh_page(browser, **context_args):
    """A page in a context of its own (cookies, permissions), closed afterwards."""
    context = browser.new_context(**context_args)
    page = context.new_page()
    page.set_default_timeout(15_000)
    try:
        yield page
    finally:
        context.close()


@pytest.fixture(params=list(WIDTHS), ids=list(WIDTHS))
def sized_page(request, browser):
    """A page at a desktop and at a phone width (the test runs once for each); page.viewport and
    page.width_name say which."""
    viewport = WIDTHS[request.param]
    phone = viewport is PHONE
    with fresh_page(browser, viewport=viewport, is_mobile=phone, has_touch=phone) as page:
        page.viewport = viewport
        page.width_name = request.param
        yield page


@pytest.fixture
def page(browser):
    with fresh_page(browser, viewport={"width": 1280, "height": 900}) as page:
        yield page


def login(page, stack: Stack, username: str, *, next_path: str = "/") -> None:
    page.goto(f"{stack.url}/accounts/login/?next={next_path}")
    page.fill("input[name=username]", username)
    page.fill("input[name=password]", PASSWORD)
    page.click("button[type=submit]")
    page.wait_for_url(f"{stack.url}{next_path}")
