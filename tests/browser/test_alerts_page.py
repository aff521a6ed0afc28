"""The Alerts page in a real browser: a person's choice is saved and comes back after a reload;
the history lists what was raised."""

from __future__ import annotations

import contextlib
import json
import time

import pytest
from playwright.sync_api import expect

from tests.browser.support import FULL_CHROMIUM, FULL_CHROMIUM_ARGS, fresh_page, login

pytestmark = pytest.mark.browser


def test_a_person_chooses_which_alerts_reach_them(browser, stack):
    errors: list[str] = []
    with fresh_page(browser, viewport={"width": 1366, "height": 800}) as page:
        page.on("pageerror", lambda e: errors.append(str(e)))
        login(page, stack, "olga", next_path="/alerts/")
        form = page.locator("#alert-choice")
        expect(form.locator('[data-field="browsers"]')).to_have_text("(0 browsers)")
        form.locator('input[value="estop"]').check()
        form.locator('input[value="not_responding"]').check()
        form.locator('select[name="min_severity"]').select_option("error")
        form.locator('input[name="by_push"]').check()
        form.locator('button[type="submit"]').click()
        expect(page.locator("#alert-choice-result")).to_have_text("Saved.")
        page.reload()
        expect(form.locator('input[value="estop"]')).to_be_checked()
        expect(form.locator('input[value="not_responding"]')).to_be_checked()
        expect(form.locator('input[value="log"]')).not_to_be_checked()
        expect(form.locator('select[name="min_severity"]')).to_have_value("error")
        expect(form.locator('input[name="by_push"]')).to_be_checked()
        expect(page.locator("#alert-history")).to_be_visible()
    assert errors == []


def test_the_service_worker_shows_a_pushed_alert_as_a_notification(browser, stack):
    """Chromium's own service-worker delivery: an alert as the server pushes it (``delivery.payload``)
    reaches the worker the Alerts page registers, which shows it as a notification. Chromium cannot
    subscribe here (there is no push service to reach), so the message comes in through DevTools'
    ``ServiceWorker.deliverPushMessage``; tests/alerts/test_delivery.py covers the server's side."""
    from robot.alerts.book import Record
    from robot.alerts.delivery import payload

    record = Record(key="log:/move_base", kind="log", severity="critical", text="/move_base: planner crashed",
                    started_at=time.time(), updated_at=time.time())
    # The whole Chromium (new headless): the headless shell refuses notifications whatever is granted.
    full = browser.browser_type.launch(executable_path=FULL_CHROMIUM, args=FULL_CHROMIUM_ARGS, headless=False)
    with contextlib.closing(full), \
            fresh_page(full, viewport={"width": 390, "height": 844}, permissions=["notifications"]) as page:
        login(page, stack, "olga", next_path="/alerts/")
        cdp = page.context.new_cdp_session(page)
        registrations: list[dict] = []
        cdp.on("ServiceWorker.workerRegistrationUpdated", lambda event: registrations.extend(event["registrations"]))
        cdp.send("ServiceWorker.enable")
        scope = page.evaluate("""async () => {
            const config = JSON.parse(document.getElementById("alerts-config").textContent);
            const registration = await navigator.serviceWorker.register(config.worker_url);
            const worker = registration.installing || registration.waiting || registration.active;
            while (worker.state !== "activated") {
                await new Promise((resolve) => worker.addEventListener("statechange", resolve, { once: true }));
            }
            return registration.scope;
        }""")
        for _ in range(100):  # DevTools' events arrive while Playwright waits
            if any(r["scopeURL"] == scope and not r["isDeleted"] for r in registrations):
                break
            page.wait_for_timeout(50)
        # The newest live registration of the scope (an earlier one of the same scope may be listed, deleted).
        registration = [r for r in registrations if r["scopeURL"] == scope and not r["isDeleted"]][-1]
        shown = []
        for _ in range(3):  # a message DevTools hands over while the worker starts may go unseen: sent again,
            cdp.send("ServiceWorker.deliverPushMessage", {  # the same tag shows one notification
                "origin": stack.url, "registrationId": registration["registrationId"],
                "data": json.dumps(payload(record))})
            for _ in range(100):  # the whole Chromium beside a loaded suite can take seconds to show it
                shown = page.evaluate("""async (scope) => {
                    const notes = await (await navigator.serviceWorker.getRegistration(scope)).getNotifications();
                    return notes.map((n) => [n.title, n.body, n.tag]);
                }""", scope)
                if shown:
                    break
                page.wait_for_timeout(50)
            if shown:
                break
    assert shown == [["Cyborg: critical", "/move_base: planner crashed", record.id]]
