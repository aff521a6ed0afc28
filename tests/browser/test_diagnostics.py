"""The diagnostics page on a phone, in a real browser against the simulator: every component's
status, message and values read without scrolling sideways."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.browser.support import PHONE, fresh_page, login

pytestmark = pytest.mark.browser

# (scrollWidth, clientWidth) of the card, everything inside it and the page.
WIDTHS = """() => {
    const card = document.getElementById('diagnostics-card');
    return [card, ...card.querySelectorAll('*'), document.scrollingElement]
        .map((el) => [el.id || el.className || el.tagName, el.scrollWidth, el.clientWidth]);
}"""

# Where each row's level, message and age sit, beside the card's edges: one snapshot (rows are redrawn live).
PLACED = """() => {
    const card = document.getElementById('diagnostics-card').getBoundingClientRect();
    return [...document.querySelectorAll('#diagnostics-table tbody tr[data-component]')].map((tr) => ({
        name: tr.dataset.component, level: tr.dataset.level, levelText: tr.querySelector('.level').textContent,
        card: {left: card.left, right: card.right},
        parts: Object.fromEntries(['.level', '.message-cell', '.age-cell'].map((sel) => {
            const el = tr.querySelector(sel), r = el.getBoundingClientRect();
            return [sel, {visible: el.checkVisibility(), left: r.left, right: r.right, width: r.width}];
        })),
    }));
}"""


def test_on_a_phone_every_component_reads_without_scrolling_sideways(browser, stack):
    with fresh_page(browser, viewport=PHONE, is_mobile=True, has_touch=True) as page:
        login(page, stack, "vera", next_path="/diagnostics/")
        rows = page.locator("#diagnostics-table tbody tr[data-component]")
        expect(rows.first).to_be_visible(timeout=15_000)
        expect(page.locator('[data-field="diagnostics.overall"]')).to_contain_text("components")
        wide = [(name, scroll, client) for name, scroll, client in page.evaluate(WIDTHS)
                if client and scroll > client]
        assert wide == []
        placed = page.evaluate(PLACED)
        assert {"RosAria: Battery", "RosAria: Motors"} <= {row["name"] for row in placed}
        for row in placed:
            assert row["level"] == row["levelText"], row
            for part, box in row["parts"].items():
                assert box["visible"] and box["width"] > 0, (row["name"], part)
                assert row["card"]["left"] <= box["left"] and box["right"] <= row["card"]["right"], (row["name"], part)
        # The key/values stay on a phone, under their component.
        expect(page.locator('tr[data-component="RosAria: Battery"] .values-col dl')).to_be_visible()
        expect(page.locator("#diagnostics-table thead")).to_be_hidden()
