"""The History page in a real browser, at a desktop and a phone width: the state timeline counts only what was recorded,
zooming (by mouse or finger) fetches finer buckets, From/To only for a custom range, text topics as a table."""

from __future__ import annotations

import re
from datetime import datetime
from zoneinfo import ZoneInfo

import pytest
from django.conf import settings
from playwright.sync_api import expect

from tests.browser.checks import HORIZONTAL_OVERFLOW
from tests.browser.support import PHONE, login

pytestmark = pytest.mark.browser

# Ten minutes of a robot that started ten minutes ago: a level every second, a startup that
# took 15 s, two things said. Policies are off so the live stack records nothing more of them.
SEED = """
import json, time
from history.models import TopicPolicy, Sample
from history.storage import write_rows
now = time.time()
Sample.objects.filter(topic__startswith="/test/").delete()
for topic, msg_type in (("/test/level", "std_msgs/Float32"), ("/test/speech", "std_msgs/String")):
    TopicPolicy.objects.update_or_create(topic=topic, defaults={"msg_type": msg_type, "mode": "off"})
began = now - 600
rows = [("/test/level", "std_msgs/Float32", began + i, json.dumps({"data": (i % 60) / 60})) for i in range(600)]
rows += [("/test/speech", "std_msgs/String", now - 300, '{"data": "Hello there"}'),
         ("/test/speech", "std_msgs/String", now - 100, '{"data": "Going to the kitchen"}')]
rows += [("/cyborg_controller/state_change", "cyborg_controller/SystemState", began + at,
          json.dumps({"event": e, "from_system_state": a, "to_system_state": b}))
         for at, e, a, b in ((0, "", "", "startup"), (15, "succeeded", "startup", "suspension"))]
TopicPolicy.objects.get_or_create(topic="/cyborg_controller/state_change",
                                  defaults={"msg_type": "cyborg_controller/SystemState", "mode": "off"})
TopicPolicy.objects.get_or_create(topic="/RosAria/battery_state_of_charge",
                                  defaults={"msg_type": "std_msgs/Float32", "mode": "off"})
rows += [("/RosAria/battery_state_of_charge", "std_msgs/Float32", now - 500 + i * 10,
          json.dumps({"data": 0.72 + i / 350})) for i in range(50)]
write_rows(rows)
"""


@pytest.fixture(scope="module")
def seeded(stack):
    stack.manage("shell", "-c", SEED)
    return stack


def timeline_rows(page) -> dict[str, str]:
    rows = page.locator("#timeline-rows tr")
    expect(rows.first).to_be_visible()
    return {r.locator("td").nth(0).inner_text(): r.locator("td").nth(1).inner_text() for r in rows.all()}


def test_history_shows_what_was_recorded_without_stale_views(sized_page, seeded):
    page = sized_page
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.on("dialog", lambda d: errors.append(f"dialog: {d.message}"))
    login(page, seeded, "vera", next_path="/history/")

    # From/To only for a custom range.
    expect(page.locator("#start")).to_be_hidden()
    page.select_option("#range", "custom")
    expect(page.locator("#start")).to_be_visible()
    page.select_option("#range", "day")
    expect(page.locator("#start")).to_be_hidden()

    # The timeline of a robot that ran ten minutes in the last day: ten minutes, not a day.
    page.click("[data-preset=timeline]")
    rows = timeline_rows(page)
    assert rows.get("startup") == "15.0 s", rows
    # At most the ten minutes seeded; less when the shared stack's robot reconnected meanwhile (another
    # test restarted it): after a reconnect no state is assumed until the robot names one.
    value, unit = rows.get("suspension", "0 ?").split()
    assert unit in ("s", "min") and 0 < float(value) * (60 if unit == "min" else 1) <= 600, rows
    expect(page.locator("#plot-info")).to_contain_text("recorded in this range")

    # A number plots; then a text topic shows as a table, and the plot goes away.
    page.select_option("#topic", "/test/level")
    page.click("#plot-form button[type=submit]")
    expect(page.locator("#chart .uplot")).to_be_visible()
    expect(page.locator("#timeline")).to_be_hidden()
    page.select_option("#topic", "/test/speech")
    expect(page.locator("#field")).to_have_value("@messages")
    assert page.evaluate("document.getElementById('plot-form').checkValidity()") is True
    page.click("#plot-form button[type=submit]")
    expect(page.locator("#messages")).to_be_visible()
    expect(page.locator("#chart")).to_be_hidden()
    expect(page.locator("#messages-rows tr")).to_have_count(2)
    expect(page.locator("#messages-rows tr").first).to_contain_text("Going to the kitchen")
    expect(page.locator("#messages-head")).to_contain_text("Time (")
    expect(page.locator("#plot-info")).to_contain_text("2 messages, newest first")
    assert page.evaluate("document.documentElement.scrollWidth <= window.innerWidth"), "the page scrolls sideways"
    assert errors == []


def drag_across(page, box, start: float, end: float) -> None:
    """Drag across the plot from ``start`` to ``end`` (fractions of its width): with the mouse on a
    desktop, with a finger on a phone (Chromium's touch input, as a phone's browser gets it)."""
    y = box["y"] + box["height"] / 2
    xs = [box["x"] + box["width"] * (start + (end - start) * k / 6) for k in range(7)]
    if page.viewport is not PHONE:
        page.mouse.move(xs[0], y)
        page.mouse.down()
        for x in xs[1:]:
            page.mouse.move(x, y)
        page.mouse.up()
        return
    cdp = page.context.new_cdp_session(page)
    cdp.send("Input.dispatchTouchEvent", {"type": "touchStart", "touchPoints": [{"x": xs[0], "y": y}]})
    for x in xs[1:]:
        cdp.send("Input.dispatchTouchEvent", {"type": "touchMove", "touchPoints": [{"x": x, "y": y}]})
    cdp.send("Input.dispatchTouchEvent", {"type": "touchEnd", "touchPoints": []})
    cdp.detach()


def test_zooming_fetches_finer_buckets(sized_page, seeded):
    page = sized_page
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    login(page, seeded, "vera", next_path="/history/")
    page.select_option("#topic", "/test/level")
    page.click("#plot-form button[type=submit]")
    expect(page.locator("#plot-info")).to_contain_text("buckets of 60 s")
    assert page.evaluate(HORIZONTAL_OVERFLOW) <= 0, "the plot makes the page scroll sideways"
    requests: list[str] = []
    page.on("request", lambda r: "/api/history/samples/" in r.url and requests.append(r.url))
    over = page.locator("#chart .u-over")
    over.scroll_into_view_if_needed()
    box = over.bounding_box()
    assert box is not None
    # The ten recorded minutes are the plot's last pixels of a day: drag from the middle of the
    # x axis to its right edge, where the data is.
    drag_across(page, box, 0.5, 0.999)
    expect(page.locator("#plot-info")).to_contain_text("(zoomed)")
    assert len(requests) == 1, requests
    text = page.locator("#plot-info").inner_text()
    width_s = float(text.split("buckets of ")[1].split(" s")[0])
    assert width_s < 60, text
    expect(page.locator("#zoom-out")).to_be_visible()
    page.click("#zoom-out")
    expect(page.locator("#plot-info")).to_contain_text("buckets of 60 s")
    expect(page.locator("#zoom-out")).to_be_hidden()
    assert errors == []


ROBOT_STATES = ["offline", "startup", "suspension", "demo", "manual", "behaviour", "idle", "navigation",
                "navigation_planning", "navigation_go_to_emotional", "navigation_go_to_schedular",
                "wandering_emotional", "show_off_mea", "conveying_emotional_state", "music_horror", "astrolanguage",
                "waking_up", "sleepy", "sleeping", "exhausted", "a_state_added_later", "and_another"]


AXIS_AT = """async (end) => {
    const { renderTimeline } = await import('/static/js/timeline.js');
    const el = (id) => document.getElementById(id);
    const start = end - 86400;
    renderTimeline({ bar: el('timeline-bar'), axisEl: el('timeline-axis'), detail: el('timeline-detail'),
                     rows: el('timeline-rows'), caption: el('timeline-caption') },
                   { start, end, totals: { idle: 86400 }, segments: [], counts: {} });
    const axis = el('timeline-axis').getBoundingClientRect();
    let spill = -Infinity, offMark = 0;
    for (const tick of el('timeline-axis').children) {
        const r = tick.getBoundingClientRect();
        spill = Math.max(spill, axis.left - r.left, r.right - axis.right);
        const mark = r.left + parseFloat(getComputedStyle(tick, '::before').left);
        offMark = Math.max(offMark, Math.abs(mark - (axis.left + axis.width * parseFloat(tick.style.left) / 100)));
    }
    return [spill, offMark];
}"""


def test_the_timeline_has_a_colour_per_state_a_time_axis_and_says_when_each_stretch_was(sized_page, seeded):
    page = sized_page
    login(page, seeded, "vera", next_path="/history/")
    colours = page.evaluate("""async (states) => {
        const { stateColors } = await import('/static/js/timeline.js');
        return stateColors(states);
    }""", ROBOT_STATES)
    assert len(set(colours.values())) == len(ROBOT_STATES), colours  # suspension and sleeping, demo and sleepy…

    page.click("[data-preset=timeline]")
    expect(page.locator("#timeline-rows tr").first).to_be_visible()
    # A 24-hour time axis in the site's zone, the date where the day changes (it spans one here).
    ticks = page.locator("#timeline-axis .timeline-tick").all_inner_texts()
    assert len(ticks) >= 2 and all(re.fullmatch(r"(\d{4}-\d{2}-\d{2} )?\d{2}:\d{2}", t) for t in ticks), ticks
    assert re.match(r"\d{4}-", ticks[0]) and sum(1 for t in ticks if "-" in t) <= 2, ticks
    expect(page.locator("#timeline-caption")).to_contain_text(re.compile(r"Times in \w+"))
    # Each stretch says its state, its times and how long it was; a tap shows the same.
    stretch = page.locator('#timeline-bar .timeline-seg[data-state="suspension"]')
    when = re.compile(r"^suspension: \d{4}-\d{2}-\d{2} \d{2}:\d{2}:\d{2} – \d{2}:\d{2}:\d{2} \w+ \(\d+\.\d min\)$")
    expect(stretch).to_have_attribute("title", when)
    stretch.dispatch_event("click")
    expect(page.locator("#timeline-detail")).to_have_text(when)
    # How often each state was entered.
    expect(page.locator("#timeline-rows tr", has_text="startup").locator("td").nth(3)).to_have_text("1")
    assert page.evaluate(HORIZONTAL_OVERFLOW) <= 0
    # Wherever the day changes (its label carries the date), at either end too, every label stays inside
    # the axis and its mark on its time.
    midnight = datetime.now(ZoneInfo(settings.TIME_ZONE)).replace(hour=0, minute=0, second=0, microsecond=0)
    for end in (midnight.timestamp() + s for s in (-60, 120, 600, 43200)):
        spill, off_mark = page.evaluate(AXIS_AT, end)
        assert spill <= 0.5 and off_mark <= 1.5, (end, spill, off_mark)


def test_plots_read_24_hour_times_in_the_site_zone_and_name_their_units(sized_page, seeded):
    page = sized_page
    login(page, seeded, "vera", next_path="/history/")
    # The time axis: 24-hour, the date on the first tick and where the day changes.
    ticks = page.evaluate("""async () => {
        const { timeTicks } = await import('/static/js/plotaxes.js');
        const t0 = Date.UTC(2026, 10, 24, 12, 0, 0) / 1000;  // 13:00 in Oslo, 14:24 is "2:24pm" in the US
        return timeTicks(null, [t0, t0 + 3600, t0 + 5040, t0 + 12 * 3600], 0, 0, 3600);
    }""")
    assert ticks == ["2026-11-24 13:00", "14:00", "14:24", "2026-11-25 01:00"], ticks

    # Battery picked by hand (no preset) is plotted in % with its unit, not as 0.72 "data".
    page.select_option("#topic", "/RosAria/battery_state_of_charge")
    page.select_option("#field", "data")
    page.select_option("#range", "hour")
    page.click("#plot-form button[type=submit]")
    over = page.locator("#chart .u-over")
    expect(over).to_be_visible()
    box = over.bounding_box()
    page.mouse.move(box["x"] + box["width"] * 0.95, box["y"] + box["height"] / 2)
    values = page.locator("#chart .u-legend .u-series .u-value")
    expect(values.nth(0)).to_have_text(re.compile(r"^\d{4}-\d{2}-\d{2} \d{2}:\d{2}:\d{2} \w+$"))
    expect(values.nth(1)).to_have_text(re.compile(r"^\d+\.\d{3} %$"))
    assert 70 <= float(values.nth(1).inner_text().split()[0]) <= 90


def _span(page) -> tuple[float, float]:
    bar = page.locator("#timeline-bar")
    return float(bar.get_attribute("data-start")), float(bar.get_attribute("data-end"))


def test_the_timeline_follows_the_chosen_range_and_zooms_like_the_plots(sized_page, seeded):
    page = sized_page
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    login(page, seeded, "vera", next_path="/history/")
    page.click("[data-preset=timeline]")
    expect(page.locator("#timeline-rows tr").first).to_be_visible()
    start, end = _span(page)
    assert end - start == pytest.approx(86400, abs=5)

    # Half an hour that ends now: Show draws the timeline of that half hour (not a table, not a day).
    zone = ZoneInfo(settings.TIME_ZONE)
    to = datetime.now(zone).replace(second=0, microsecond=0)
    since = to.timestamp() - 1800
    page.select_option("#range", "custom")
    page.fill("#start", datetime.fromtimestamp(since, zone).strftime("%Y-%m-%d %H:%M"))
    page.fill("#end", to.strftime("%Y-%m-%d %H:%M"))
    expect(page.locator("#field")).to_have_value("@timeline")
    page.click("#plot-form button[type=submit]")
    expect(page.locator("#timeline")).to_be_visible()
    expect(page.locator("#timeline-bar")).to_have_attribute("data-start", f"{since:.0f}")
    assert _span(page) == (pytest.approx(since), pytest.approx(to.timestamp()))
    # Its axis is that half hour's clock: every label a minute inside it.
    minutes = {datetime.fromtimestamp(since + 60 * i, zone).strftime("%H:%M") for i in range(31)}
    ticks = [t.split()[-1] for t in page.locator("#timeline-axis .timeline-tick").all_inner_texts()]
    assert len(ticks) >= 2 and set(ticks) <= minutes, ticks
    expect(page.locator("#timeline-rows tr", has_text="suspension")).to_be_visible()

    # A drag across its middle half zooms to that quarter hour; Whole range goes back.
    bar = page.locator("#timeline-bar")
    bar.scroll_into_view_if_needed()
    box = bar.bounding_box()
    assert box is not None
    drag_across(page, box, 0.25, 0.75)
    expect(page.locator("#plot-info")).to_contain_text("(zoomed)")
    start, end = _span(page)
    assert since + 300 < start < since + 600 and to.timestamp() - 600 < end < to.timestamp() - 300, (start, end)
    expect(page.locator("#zoom-out")).to_be_visible()
    page.click("#zoom-out")
    expect(page.locator("#zoom-out")).to_be_hidden()
    expect(page.locator("#plot-info")).not_to_contain_text("(zoomed)")
    expect(page.locator("#timeline-bar")).to_have_attribute("data-start", f"{since:.0f}")
    assert _span(page) == (pytest.approx(since), pytest.approx(to.timestamp()))
    assert errors == []
