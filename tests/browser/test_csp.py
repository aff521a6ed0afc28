"""Every page runs under the Content-Security-Policy in a real Chromium: ours, the login page, the
admin (index, a change list, change forms), the API's browsable pages and its docs (Swagger UI).
Any console message or securitypolicyviolation event about the policy fails the test."""

from __future__ import annotations

import re

import pytest
from playwright.sync_api import expect

from tests.browser.support import login
from tests.browser.test_pages import OTHER_PAGES, our_pages, settle

pytestmark = pytest.mark.browser

# Kept by the page until read: what the browser reported as blocked by the policy.
RECORD_VIOLATIONS = """(() => {
    window.cspViolations = [];
    document.addEventListener("securitypolicyviolation", (e) =>
        window.cspViolations.push(`${e.effectiveDirective} blocked ${e.blockedURI || "inline"}`
                                  + ` at ${e.sourceFile}:${e.lineNumber} (${e.sample})`));
})()"""
ABOUT_CSP = re.compile(r"Content.Security.Policy", re.I)
THEIR_PAGES = ["/admin/", "/admin/auth/user/", "/admin/robot/location/add/", "/admin/history/topicpolicy/",
               "/api/robot/state/", "/api/locations/", "/api/audit/", "/api/", "/api/docs/"]
OVERLAYS = "/api/me/map-overlays/"


def api(page, stack, method: str, path: str, body: dict | None = None) -> dict:
    token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
    res = page.request.fetch(f"{stack.url}{path}", method=method, data=body,
                             headers={"X-CSRFToken": token, "Referer": f"{stack.url}/map/"})
    assert res.ok, (res.status, res.text())
    return res.json()


def test_every_page_runs_without_a_content_security_policy_violation(page, stack):
    reported: list[str] = []
    page.on("console", lambda msg: ABOUT_CSP.search(msg.text) and reported.append(f"{page.url}: {msg.text}"))
    page.add_init_script(RECORD_VIOLATIONS)

    def visit(path: str) -> None:
        response = page.goto(f"{stack.url}{path}")
        assert response is not None and "default-src 'self'" in response.headers["content-security-policy"], path
        if path == "/statemachine/":  # Graphviz, compiled to WebAssembly, has laid the graph out
            expect(page.locator("#smach-graph svg")).to_be_visible(timeout=20_000)
        elif path == "/api/docs/":  # Swagger UI's start-up script ran and drew the API
            expect(page.locator(".swagger-ui .opblock").first).to_be_visible()
            page.locator(".swagger-ui .opblock-summary").first.click()  # a section opened, as people do
        settle(page, path)
        reported.extend(f"{path}: {v}" for v in page.evaluate("() => window.cspViolations"))

    visit("/accounts/login/")
    login(page, stack, "ada")
    overlays = api(page, stack, "GET", OVERLAYS)
    api(page, stack, "PATCH", OVERLAYS, dict.fromkeys(overlays, True))  # every overlay drawn on the map page
    try:
        pages = our_pages(page, stack)
        for path in pages:
            visit(path)
            # Its live socket is open: connect-src 'self' lets a page reach ws:// on its own host and port.
            expect(page.locator("#link-pill")).to_have_text("robot online")
        for path in THEIR_PAGES:
            visit(path)
            if path == "/admin/auth/user/":  # and a person's change form, from the list
                with page.expect_navigation():
                    page.locator("#result_list tbody a").first.click()
                settle(page, path)
                reported.extend(page.evaluate("() => window.cspViolations"))
    finally:
        api(page, stack, "PATCH", OVERLAYS, overlays)
    assert OTHER_PAGES.keys() <= {*THEIR_PAGES}, "a page linked from the navigation is not checked"
    assert len(pages) >= 8
    assert reported == []
