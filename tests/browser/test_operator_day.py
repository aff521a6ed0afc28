"""What an operator meets every day, at a desktop and a phone width: alerts with the time they began,
acknowledged once for every page and kept in the history, one time zone everywhere (labelled), every
command confirmed, a scale on the map."""

from __future__ import annotations

import json
import math
import re
import time
import urllib.request
from datetime import datetime
from zoneinfo import ZoneInfo

import pytest
from django.conf import settings
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser

ERROR = 8
CLOCK = r"\d{2}:\d{2}:\d{2}"
DATE_TIME = rf"\d{{4}}-\d{{2}}-\d{{2}} {CLOCK}"


def robot_logs(stack, node: str, text: str, *, age_s: float = 0.0, level: int = ERROR) -> None:
    """A robot node writes a line to /rosout (through the simulator)."""
    stamp = time.time() - age_s
    msg = {"header": {"stamp": {"secs": int(stamp), "nsecs": int(stamp % 1 * 1e9)}}, "level": level,
           "name": node, "msg": text, "file": "", "function": "", "line": 0, "topics": []}
    body = json.dumps({"topic": "/rosout", "msg": msg}).encode()
    request = urllib.request.Request(f"http://127.0.0.1:{stack.video_port}/sim/publish", data=body, method="POST")
    with urllib.request.urlopen(request, timeout=5) as res:
        assert json.load(res)["published"] == 1


def test_alerts_have_a_time_an_acknowledgement_and_a_history(sized_page, stack):
    page = sized_page
    node = f"/alerting_{page.width_name}"
    zone = datetime.now(ZoneInfo(settings.TIME_ZONE)).strftime("%Z")
    login(page, stack, "otto")
    expect(page.locator("#link-pill")).to_have_text("robot online")
    robot_logs(stack, f"{node}_old", "from long ago", age_s=3600)  # older than an alert's lifetime
    robot_logs(stack, node, "laser driver died")
    alert = page.locator(f'#alert-strip [data-alert-key="log:{node}"]')
    expect(alert).to_contain_text(f"ERROR from {node}: laser driver died")
    expect(alert.locator("time")).to_have_text(re.compile(rf"^{CLOCK} {zone}$"))
    began = alert.locator("time").get_attribute("datetime")
    # The robot log shows the line with its date, in the site's zone.
    line = page.locator(".log-line", has_text=f"{node}: laser driver died").first
    expect(line).to_have_text(re.compile(rf"^{DATE_TIME} \[ERROR\] {node}: laser driver died$"))
    # The same source again: one alert that counts, not a pile.
    robot_logs(stack, node, "laser driver died")
    expect(alert.locator(".strip-count")).to_have_text("×2")
    for k in range(4):
        robot_logs(stack, f"{node}_{k}", "also broken")
    expect(page.locator("#alert-strip .strip-more")).to_contain_text("more alert")  # three shown, the rest behind it
    expect(page.locator(f'#alert-strip [data-alert-key="log:{node}_old"]')).to_have_count(0)

    # Acknowledged, it goes from every page, and stays gone after a reload; the history keeps who and when.
    page.locator("#alert-strip .strip-more").click()
    newest = page.locator(f'#alert-strip [data-alert-key="log:{node}_3"]')
    newest.get_by_role("button", name="Acknowledge").click()
    expect(newest).to_have_count(0)
    page.reload()
    page.locator("#alert-strip .strip-more").click()
    expect(page.locator(f'#alert-strip [data-alert-key="log:{node}_2"]')).to_be_visible()
    expect(page.locator(f'#alert-strip [data-alert-key="log:{node}_3"]')).to_have_count(0)
    # When it began survives the reload.
    expect(alert.locator("time")).to_have_attribute("datetime", began)
    page.goto(f"{stack.url}/alerts/")
    row = page.locator("#alert-history tr", has_text=f"ERROR from {node}_3: also broken")
    expect(row).to_contain_text("otto")


def test_times_are_in_the_site_zone_and_labelled(sized_page, stack):
    page = sized_page
    zone = ZoneInfo(settings.TIME_ZONE)
    login(page, stack, "olga")
    # A command, so the Activity page has a row and the card a result line.
    page.fill("#card-voice textarea[name=text]", "What time is it?")
    page.click("#card-voice .speech-form button[type=submit]")
    result = page.locator('#card-voice [data-result="*"], #card-voice [data-result="speech"]').first
    expect(result).to_have_text(re.compile(rf"^✓ .+ · {CLOCK} [A-Z][A-Z+\d]+$"))  # the zone named
    page.goto(f"{stack.url}/activity/")
    abbreviation = datetime.now(zone).strftime("%Z")
    expect(page.locator("#activity tbody tr").first.locator("time")).to_have_text(
        re.compile(rf"^{DATE_TIME} {abbreviation}$"))
    # History: typed dates (not the browser's locale format), read in the site's zone.
    page.goto(f"{stack.url}/history/")
    page.select_option("#range", "custom")
    expect(page.locator("#start")).to_have_attribute("type", "text")
    expect(page.locator("#start")).to_have_value(re.compile(r"^\d{4}-\d{2}-\d{2} \d{2}:\d{2}$"))
    expect(page.locator("[data-zone-label]")).to_contain_text(settings.TIME_ZONE)
    for text in ("2026-01-02 03:04", "2026-07-01 12:00:30"):
        expected = datetime.fromisoformat(text).replace(tzinfo=zone).timestamp()
        parsed = page.evaluate("""async (text) => {
            const src = [...document.scripts].find((s) => s.src.includes('/js/header.js')).src;
            const { parseSiteTime } = await import(src.replace('header.js', 'time.js'));
            return parseSiteTime(text);
        }""", text)
        assert parsed == expected, text


def test_sound_and_dome_commands_confirm_and_the_map_has_a_scale(sized_page, stack):
    page = sized_page
    login(page, stack, "otto")
    for card, command in (("#card-voice", "playback"), ("#card-expression", "dome")):
        page.click(f'{card} form[data-command="{command}"] button[type=submit]')
        expect(page.locator(f'{card} [data-result="*"]')).to_have_text(re.compile(rf"^✓ .+ · {CLOCK} [A-Z][A-Z+\d]+$"))
    page.goto(f"{stack.url}/map/")
    expect(page.locator("#map-view")).to_have_attribute("data-ready", "1")
    scale = page.locator("#map-scale")
    expect(scale).to_be_visible()
    before = check_scale(page)
    for _ in range(3):  # 1.4³: more than the 2.5× a bar may grow before it steps to the next round length
        page.click("#zoom-in")
    expect(scale).not_to_have_attribute("data-metres", f"{before:g}")
    check_scale(page)


def check_scale(page) -> float:
    """The scale bar's label is a round length and its bar is as long on screen as that much map."""
    scale = page.locator("#map-scale")
    metres = float(scale.get_attribute("data-metres"))
    label = scale.locator(".map-scale-label").inner_text()
    assert label == (f"{metres:g} m" if metres >= 1 else f"{round(metres * 100)} cm")
    bar = scale.locator(".map-scale-bar").bounding_box()["width"]
    ends = [page.evaluate("([x, y]) => window.cyborgMap.toClient(x, y)", p) for p in ([0, 0], [metres, 0])]
    assert bar == pytest.approx(math.dist(*ends), abs=1.5)
    return metres
