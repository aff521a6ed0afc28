"""The dark theme: it follows the system's setting (prefers-color-scheme), and a person's own choice
(light or dark, kept on the server) overrides it on every page, after a reload too. In it every page
is dark, the map (dark floor, light walls), the state machine and the API docs included, and every
text reads at WCAG AA contrast against what it is drawn on."""

from __future__ import annotations

import contextlib
import io
import re

import pytest
from playwright.sync_api import TimeoutError as PlaywrightTimeout
from playwright.sync_api import expect

from tests.browser.support import fresh_page, login
from tests.browser.test_alerts import Robot
from tests.stack import Stack

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


# Every visible element with text of its own: its colour (an SVG text's fill) against the background it
# is drawn on (the first opaque background up its ancestors, the translucent ones between laid over it;
# for an SVG text, the filled shape under it), its opacity and its ancestors' applied, as WCAG computes
# contrast. Disabled controls are exempt (WCAG 1.4.3). Returns the texts under `least`.
LOW_CONTRAST = """async (least) => {
    const parse = (css) => {
        const m = css.match(/rgba?\\(([\\d.]+)[ ,]+([\\d.]+)[ ,]+([\\d.]+)(?:[ ,/]+([\\d.]+%?))?\\)/);
        if (!m) return css === 'transparent' || css === 'none' || css === '' ? [0, 0, 0, 0] : null;
        const a = m[4] === undefined ? 1 : m[4].endsWith('%') ? parseFloat(m[4]) / 100 : Number(m[4]);
        return [Number(m[1]), Number(m[2]), Number(m[3]), a];
    };
    const over = (top, bottom) => [0, 1, 2].map((i) => top[i] * top[3] + bottom[i] * (1 - top[3])).concat(1);
    const luminance = ([r, g, b]) => [r, g, b].map((v) => {
        v /= 255;
        return v <= 0.03928 ? v / 12.92 : ((v + 0.055) / 1.055) ** 2.4;
    }).reduce((sum, v, i) => sum + v * [0.2126, 0.7152, 0.0722][i], 0);
    const ratio = (a, b) => {
        const [hi, lo] = [luminance(a), luminance(b)].sort((x, y) => y - x);
        return (hi + 0.05) / (lo + 0.05);
    };
    const canvas = parse(getComputedStyle(document.documentElement).backgroundColor)[3] > 0
        ? parse(getComputedStyle(document.documentElement).backgroundColor)
        : parse(getComputedStyle(document.body).backgroundColor);
    const backdrop = canvas && canvas[3] > 0 ? over(canvas, [255, 255, 255, 1]) : [255, 255, 255, 1];
    const htmlBackground = (el) => {
        const layers = [];
        for (let node = el; node; node = node.parentElement) {
            const bg = parse(getComputedStyle(node).backgroundColor);
            if (bg && bg[3] > 0) layers.push(bg);
            if (bg && bg[3] >= 1) break;
        }
        return layers.reverse().reduce((below, layer) => over(layer, below), backdrop);
    };
    const svgBackground = (el) => {
        el.scrollIntoView({ block: 'center', inline: 'center' });
        const r = el.getBoundingClientRect();
        for (const hit of document.elementsFromPoint(r.left + r.width / 2, r.top + r.height / 2)) {
            if (hit === el || el.contains(hit)) continue;
            if (hit instanceof SVGElement && !(hit instanceof SVGSVGElement)) {
                const fill = parse(getComputedStyle(hit).fill);
                if (fill && fill[3] > 0) return over(fill, htmlBackground(hit.ownerSVGElement));
                continue;
            }
            return htmlBackground(hit);
        }
        return backdrop;
    };
    const failures = [];
    for (const el of document.querySelectorAll('body *')) {
        if (['SCRIPT', 'STYLE', 'OPTION', 'NOSCRIPT', 'TEMPLATE'].includes(el.tagName)) continue;
        const own = [...el.childNodes].filter((n) => n.nodeType === Node.TEXT_NODE)
            .map((n) => n.textContent).join('').trim();
        if (!own || !el.checkVisibility({ opacityProperty: true, visibilityProperty: true })) continue;
        if (el.getClientRects().length === 0 || el.closest(':disabled, [aria-disabled=true]')) continue;
        const style = getComputedStyle(el);
        const svg = el instanceof SVGElement;
        const ink = parse(svg ? style.fill : style.color);
        if (!ink) { failures.push({ text: own.slice(0, 40), note: `colour ${style.color}` }); continue; }
        let opacity = ink[3];
        for (let node = el; node; node = node.parentElement) opacity *= Number(getComputedStyle(node).opacity);
        const bg = svg ? svgBackground(el) : htmlBackground(el);
        const fg = over([ink[0], ink[1], ink[2], opacity], bg);
        const r = ratio(fg, bg);
        if (r >= least) continue;
        const classes = typeof el.className === 'string' && el.className
            ? '.' + el.className.trim().split(/\\s+/).join('.') : '';
        failures.push({ text: own.slice(0, 40), tag: el.tagName.toLowerCase() + (el.id ? '#' + el.id : '') + classes,
            ratio: Math.round(r * 100) / 100, ink: `rgb(${fg.slice(0, 3).map(Math.round)})`,
            on: `rgb(${bg.slice(0, 3).map(Math.round)})` });
    }
    window.scrollTo(0, 0);
    return failures;
}"""
DARK_PAGES = ["/", "/map/", "/drive/", "/topics/", "/statemachine/", "/diagnostics/", "/history/",
              "/history/replay/", "/history/incidents/", "/activity/", "/alerts/", "/api/docs/"]


def luminances(png: bytes) -> list[float]:
    from PIL import Image

    image = Image.open(io.BytesIO(png)).convert("L")
    return [v / 255 for v in image.tobytes()]


def wait_drawn(page, path: str) -> None:
    """Until what the page draws from the robot or the server is there (the map, the graph, the docs)."""
    if path == "/map/":
        page.wait_for_function("() => document.getElementById('map-image').naturalWidth > 0")
        expect(page.locator("#map-empty")).to_be_hidden(timeout=15_000)
    elif path == "/statemachine/":
        expect(page.locator("#smach-graph svg g.node").first).to_be_visible(timeout=15_000)
    elif path == "/api/docs/":
        expect(page.locator(".swagger-ui .opblock").first).to_be_visible(timeout=20_000)
    with contextlib.suppress(PlaywrightTimeout):
        page.wait_for_load_state("networkidle", timeout=3000)


@pytest.fixture(scope="module")
def alerting_stack():
    """A stack of its own with alerts in every page's strip (an error and a warning from the robot's diagnostics)."""
    with Stack() as running:
        running.wait_robot_online()
        robot = Robot(running)
        try:
            robot.publish("diagnostics", {"header": {}, "status": [
                {"level": 2, "name": "Test: Motor", "message": "overheating", "hardware_id": "t", "values": []},
                {"level": 1, "name": "Test: Fan", "message": "slow", "hardware_id": "t", "values": []}]})
            yield running
        finally:
            robot.close()


@pytest.mark.timeout(360)  # a stack of its own, then every page
def test_in_the_dark_theme_every_page_is_dark_and_its_text_readable(browser, alerting_stack):
    stack = alerting_stack
    with fresh_page(browser, viewport={"width": 1366, "height": 800}, color_scheme="dark") as page:
        login(page, stack, "ada")
        problems: dict[str, object] = {}
        for path in DARK_PAGES:
            page.goto(f"{stack.url}{path}")
            wait_drawn(page, path)
            if path != "/api/docs/":
                expect(page.locator("#alert-strip .strip-alert")).to_have_count(2)
            if path == "/api/docs/":  # an operation opened: its parameters and responses
                page.locator(".swagger-ui .opblock-summary").first.click()
                expect(page.locator(".swagger-ui .opblock-body").first).to_be_visible()
            low = page.evaluate(LOW_CONTRAST, 4.5)
            if low:
                problems[f"{path} text under 4.5:1"] = low[:6]
            # What the eye sees (filters included): a dark screen, not a light panel on a dark page (the
            # camera's pictures are what they are).
            shot = luminances(page.screenshot(mask=[page.locator("img:not(#map-image), video")], mask_color="#000"))
            light = sum(v > 0.6 for v in shot) / len(shot)
            if light > 0.15:
                problems[f"{path} light area"] = f"{light:.0%} of the screen is light"
        assert problems == {}


@pytest.mark.timeout(360)
def test_in_the_dark_theme_the_map_is_dark_with_light_walls(browser, alerting_stack):
    stack = alerting_stack
    with fresh_page(browser, viewport={"width": 1366, "height": 800}, color_scheme="dark") as page:
        login(page, stack, "olga", next_path="/map/")
        wait_drawn(page, "/map/")
        shot = luminances(page.locator("#map-view").screenshot())
        dark = sum(v < 0.3 for v in shot) / len(shot)
        walls = sum(v > 0.6 for v in shot) / len(shot)
        assert dark > 0.6, f"only {dark:.0%} of the map is dark"
        assert walls > 0.002, f"no light walls ({walls:.2%} of the map)"
