"""The state machine page and the diagnostics on the dashboard, in a real browser against the
simulator: clicking a transition in the graph changes the robot's state (and is audited), viewers
see the graph read-only, and a WARN component shows on the dashboard's alert strip until it recovers.
Each test leaves the shared robot as it found it: in suspension, motors enabled."""

from __future__ import annotations

import re
import time

import pytest
from playwright.sync_api import expect

from tests.browser.support import PHONE, fresh_page, login

pytestmark = pytest.mark.browser

CURRENT = "#smach-graph g.node.current"


def _post(page, stack, path: str, body: dict | None = None):
    token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
    return page.request.post(f"{stack.url}{path}", data=body or {}, headers={"X-CSRFToken": token})


def _edge(page, source: str, event: str):
    return page.locator(f'#smach-graph g.edge[data-from="{source}"][data-event="{event}"]')


# Each edge's label box: what a finger hits (the padded target when there is one, else the text).
LABEL_BOXES = """() => [...document.querySelectorAll('#smach-graph g.edge')].flatMap((edge) => {
    const target = edge.querySelector('.label-hit') || edge.querySelector('text');
    if (!target) return [];
    const r = target.getBoundingClientRect();
    return [{id: edge.id, event: edge.dataset.event, left: r.left, right: r.right, top: r.top, bottom: r.bottom,
             clickable: edge.classList.contains('clickable')}];
})"""


def _overlapping(boxes: list[dict]) -> list[tuple[str, str]]:
    return [(a["id"], b["id"]) for i, a in enumerate(boxes) for b in boxes[i + 1:]
            if a["left"] < b["right"] and b["left"] < a["right"] and a["top"] < b["bottom"] and b["top"] < a["bottom"]]


def test_clicking_a_transition_in_the_graph_sends_its_event_and_the_graph_follows(page, stack):
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    login(page, stack, "otto", next_path="/statemachine/")
    # A fresh simulator spends its start-up (15 s) in startup before suspension.
    expect(page.locator(CURRENT)).to_have_attribute("data-path", "/SM_ROOT/suspension", timeout=40_000)
    expect(page.locator("#smach-graph g.cluster")).to_have_count(2)  # behaviour, and navigation inside it
    assert _overlapping(page.evaluate(LABEL_BOXES)) == []
    edge = _edge(page, "/SM_ROOT/suspension", "manual_start")
    expect(edge).to_have_class("edge available clickable")
    try:
        edge.locator("text").click()  # its label, as a person would
        expect(page.locator(CURRENT)).to_have_attribute("data-path", "/SM_ROOT/manual", timeout=10_000)
        expect(page.locator('[data-field="smach.current"]')).to_have_text("manual")
        expect(edge).not_to_have_class("edge available clickable")  # suspension's edges are no longer on offer
        audit = page.request.get(f"{stack.url}/api/audit/?action=event&user=otto").json()
        assert any(e["params"] == {"event": "manual_start"} and e["ok"] for e in audit["results"])
        back = _edge(page, "/SM_ROOT/manual", "aborted")
        expect(back).to_have_class("edge available clickable")
        back.locator("text").click()
        expect(page.locator(CURRENT)).to_have_attribute("data-path", "/SM_ROOT/suspension", timeout=10_000)
    finally:
        if page.locator(CURRENT).get_attribute("data-path") != "/SM_ROOT/suspension":
            _post(page, stack, "/api/robot/mode/", {"mode": "stop"})
    assert errors == []


def test_on_a_phone_the_graph_labels_stand_apart_and_a_tap_on_one_sends_its_event(browser, stack):
    with fresh_page(browser, viewport=PHONE, is_mobile=True, has_touch=True) as page:
        login(page, stack, "otto", next_path="/statemachine/")
        expect(page.locator(CURRENT)).to_have_attribute("data-path", "/SM_ROOT/suspension", timeout=40_000)
        edge = _edge(page, "/SM_ROOT/suspension", "manual_start")
        expect(edge).to_have_class("edge available clickable")
        boxes = page.evaluate(LABEL_BOXES)
        assert len(boxes) > 40  # every outcome edge of the simulator's machine is labelled
        assert _overlapping(boxes) == []
        targets = [b for b in boxes if b["clickable"]]
        assert targets and all(min(b["right"] - b["left"], b["bottom"] - b["top"]) >= 24 for b in targets), targets
        try:
            edge.locator("text").tap()
            expect(page.locator(CURRENT)).to_have_attribute("data-path", "/SM_ROOT/manual", timeout=10_000)
            back = _edge(page, "/SM_ROOT/manual", "aborted")
            expect(back).to_have_class("edge available clickable")
            # A tap just above the word, inside its target, counts too.
            back.locator("text").scroll_into_view_if_needed()
            text = back.locator("text").bounding_box()
            page.touchscreen.tap(text["x"] + text["width"] / 2, text["y"] - 3)
            expect(page.locator(CURRENT)).to_have_attribute("data-path", "/SM_ROOT/suspension", timeout=10_000)
        finally:
            if page.locator(CURRENT).get_attribute("data-path") != "/SM_ROOT/suspension":
                _post(page, stack, "/api/robot/mode/", {"mode": "stop"})


def test_a_viewer_sees_the_graph_but_cannot_send_events(page, stack):
    login(page, stack, "vera", next_path="/statemachine/")
    expect(page.locator(CURRENT)).to_be_visible(timeout=40_000)
    expect(page.locator("#smach-graph g.edge.available").first).to_be_visible()
    expect(page.locator("#smach-graph g.edge.clickable")).to_have_count(0)
    expect(page.locator("#smach-events button").first).to_be_disabled()
    # How long it has been in this state: a duration, not "for 2 s ago".
    expect(page.locator('[data-age="smach_active"]')).to_have_text(re.compile(r"^in this state for \d+ (s|min|h)$"))


def shown_alert(page, key: str, timeout: float = 10.0):
    """The header strip's alert with this key, the strip opened if it hides it behind "more"."""
    alert = page.locator(f'#alert-strip [data-alert-key="{key}"]')
    deadline = time.monotonic() + timeout
    while not alert.count() and time.monotonic() < deadline:
        more = page.locator("#alert-strip .strip-more")
        if more.count() and "more alert" in (more.text_content() or ""):
            more.click()
        page.wait_for_timeout(100)
    return alert


def test_a_warn_diagnostic_shows_on_the_alert_strip_until_it_recovers(page, stack):
    login(page, stack, "otto")
    disable = page.locator('[data-command="motors"][data-body=\'{"enabled": false}\']')
    enable = page.locator('[data-command="motors"][data-body=\'{"enabled": true}\']')
    expect(page.locator('[data-field="diagnostics.summary"]')).to_contain_text("OK", timeout=15_000)
    try:
        disable.click()
        alert = shown_alert(page, "diag:RosAria: Motors")
        expect(alert).to_contain_text("RosAria: Motors: WARN · Motors disabled", timeout=10_000)
        expect(alert).to_have_class("strip-alert strip-warning")
        page.goto(f"{stack.url}/diagnostics/")
        row = page.locator('#diagnostics-table tr[data-component="RosAria: Motors"]')
        expect(row).to_have_attribute("data-level", "WARN")
        expect(row.locator(".level")).to_have_class("level level-warn")
        page.goto(f"{stack.url}/")
        alert = shown_alert(page, "diag:RosAria: Motors")
        expect(alert).to_be_visible()
        enable.click()
        expect(alert).to_have_count(0, timeout=10_000)
    finally:
        assert _post(page, stack, "/api/robot/motors/", {"enabled": True}).ok  # others share the robot


def test_the_sonar_and_bumpers_show_on_the_dashboard_and_the_sonar_on_the_map(page, stack):
    login(page, stack, "vera")
    card = page.locator("#card-sensors")
    expect(card.locator('[data-field="sonar.nearest"]')).to_have_text(re.compile(r"^\d+\.\d\d m$"), timeout=15_000)
    expect(card.locator(".beam")).to_have_count(8)  # the ring's eight sonars (echoes beyond 3 m at the edge)
    expect(card.locator('[data-field="bumpers.state"]')).to_have_text("clear")
    expect(card.locator(".bumper")).to_have_count(10)  # five segments front and rear, none pressed
    expect(card.locator(".bumper.pressed")).to_have_count(0)
    page.goto(f"{stack.url}/map/")
    box = page.locator('input[data-overlay="sonar"]')
    was_on = box.is_checked()
    try:
        box.check()
        note = page.locator('[data-note="sonar"]')
        expect(note).to_have_text(re.compile(r"^\d+ echoes, nearest \d+\.\d\d m$"), timeout=15_000)
    finally:
        box.set_checked(was_on)  # the choice is remembered per user
