"""The dark theme: it follows the system's setting (prefers-color-scheme), and a person's own choice
(light or dark, kept on the server) overrides it on every page, after a reload too."""

from __future__ import annotations

import re

import pytest
from playwright.sync_api import expect

from tests.browser.support import fresh_page, login

pytestmark = pytest.mark.browser

LUMINANCE = """() => {
    const [r, g, b] = getComputedStyle(document.body).backgroundColor.match(/\\d+/g).map(Number);
    return (0.2126 * r + 0.7152 * g + 0.0722 * b) / 255;
}"""


def choose(page, theme: str) -> None:
    with page.expect_response(lambda r: "/api/me/theme/" in r.url and r.request.method == "PATCH"):
        page.select_option("#theme-select", theme)


@pytest.mark.parametrize("system", ["dark", "light"])
def test_the_theme_follows_the_system_until_a_person_chooses(browser, stack, system):
    with fresh_page(browser, viewport={"width": 1366, "height": 800}, color_scheme=system) as page:
        login(page, stack, "olga")
        expect(page.locator("#theme-select")).to_have_value("system")
        dark = page.evaluate(LUMINANCE) < 0.3
        assert dark is (system == "dark")
        other = "light" if system == "dark" else "dark"
        try:
            choose(page, other)
            assert (page.evaluate(LUMINANCE) < 0.3) is (other == "dark")
            for path in ("/map/", "/history/"):  # every page, after a reload too
                page.goto(f"{stack.url}{path}")
                expect(page.locator("html")).to_have_attribute("data-theme", other)
                assert (page.evaluate(LUMINANCE) < 0.3) is (other == "dark"), path
            # The cards' text stays readable on its background.
            ink = page.evaluate("() => getComputedStyle(document.querySelector('.card')).color")
            assert re.match(r"rgb\(", ink)
        finally:
            choose(page, "system")
        assert (page.evaluate(LUMINANCE) < 0.3) is (system == "dark")
