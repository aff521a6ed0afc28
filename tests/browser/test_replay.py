"""Replay and the black box in a real browser, on a stack of their own (a short incident window, an
E-STOP that touches no other test): a recorded simulator session replays with the recorded pose and
state at three moments, the scrubber moves the map and the camera frame, speed changes the pace;
an E-STOP makes an incident holding the frames before it, listed with a thumbnail and who pressed it,
and its MCAP opens with the mcap reader with the camera and pose over the incident's span."""

from __future__ import annotations

import io
import json
import time

import pytest
from mcap.reader import make_reader
from playwright.sync_api import expect

from tests.browser.support import login
from tests.helpers import wait_until
from tests.stack import Stack

pytestmark = pytest.mark.browser

BEFORE_S, AFTER_S = 8.0, 3.0

RECORDED = """
import json
from history.models import Sample
from robot import interface as ri
pose, state = ri.topic("robot_pose").name, ri.topic("state_change").name
rows = Sample.objects.filter(topic__in=[pose, state], received_at__gte=utc(START), received_at__lte=utc(END))
rows = rows.order_by("received_at").values_list("topic", "received_at", "data")
print(json.dumps([[t, at.timestamp(), d] for t, at, d in rows]))
"""


@pytest.fixture(scope="module")
def replay_stack():
    env = {"INCIDENT_BEFORE_S": str(BEFORE_S), "INCIDENT_AFTER_S": str(AFTER_S), "CAMERA_RECORD_FPS": "2"}
    with Stack(env=env) as running:
        running.wait_robot_online()
        running.manage("shell", "-c", "from history.defaults import ensure_default_policies; ensure_default_policies()")
        # Recorded from when the recorder has read the policies (it reloads them every second or so).
        running.started_at = time.time() + 2.0  # type: ignore[attr-defined]
        yield running


def _post(page, stack, path: str, body: dict | None = None):
    token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
    return page.request.post(f"{stack.url}{path}", data=body or {}, headers={"X-CSRFToken": token})


def _recorded(stack, start: float, end: float) -> list:
    code = f"from history.storage import utc\nSTART, END = {start}, {end}\n" + RECORDED
    return json.loads(stack.manage("shell", "-c", code).strip().splitlines()[-1])


def _expected_at(samples: list, topic_suffix: str, t: float) -> dict:
    return [d for topic, at, d in samples if topic.endswith(topic_suffix) and at <= t][-1]


def test_a_recorded_session_replays_as_it_was(page, replay_stack):
    stack = replay_stack
    login(page, stack, "otto", next_path="/history/incidents/")
    began = time.time()
    assert _post(page, stack, "/api/robot/mode/", {"mode": "manual"}).ok
    assert _post(page, stack, "/api/navigation/goal/", {"x": 1.0, "y": -2.0, "yaw": 0.0}).ok
    time.sleep(14)
    ended = time.time() - 1.0
    samples = _recorded(stack, began, ended)
    poses = [at for topic, at, _ in samples if topic.endswith("robot_pose")]
    assert len(poses) >= 20, "the pose was not recorded at 2 Hz"

    page.goto(f"{stack.url}/history/replay/?start={began}&end={ended}&t={began + 1}")
    expect(page.locator("#replay-banner")).to_contain_text("REPLAY")
    expect(page.locator("#play")).to_be_visible()
    # No command controls (the site-wide E-STOP stays: it stops the real robot, whatever the page shows).
    assert page.locator("[data-command], [data-commands], [data-mode], #card-mode, #joystick").count() == 0

    seen = []
    for fraction in (0.2, 0.55, 0.9):
        moment = began + fraction * (ended - began)
        pose = _expected_at(samples, "robot_pose", moment)["position"]
        state = _expected_at(samples, "state_change", moment)["to_system_state"]
        page.goto(f"{stack.url}/history/replay/?start={began}&end={ended}&t={moment}")
        expect(page.locator("#replay-map")).to_have_attribute("data-pose", f"{pose['x']:.3f},{pose['y']:.3f}")
        expect(page.locator("#r-state")).to_have_text(state)
        if fraction == 0.9:  # the mode asked for on this page's stack (nothing is published on robot_mode), and reached
            assert state == "manual", state
            expect(page.locator("#r-mode")).to_have_text("manual by otto")
            expect(page.locator("#r-mode-reached")).to_have_text("manual ✓")
        expect(page.locator("#replay-frame")).not_to_have_attribute("data-t", "")
        frame_t = float(page.locator("#replay-frame").get_attribute("data-t"))
        assert moment - 1.0 < frame_t <= moment
        seen.append((pose["x"], pose["y"]))
    assert len(set(seen)) > 1, "the robot did not move: nothing to replay"

    # The scrubber moves the map and the camera frame.
    before = (page.locator("#replay-map").get_attribute("data-pose"),
              page.locator("#replay-frame").get_attribute("data-t"))
    page.locator("#scrubber").fill("300")
    wait_until(lambda: page.locator("#replay-frame").get_attribute("data-t") != before[1], timeout=10,
               what="the camera frame to follow the scrubber")
    expect(page.locator("#replay-map")).not_to_have_attribute("data-pose", before[0])

    # Speed changes the pace: replayed seconds per wall second.
    def pace(speed: str) -> float:
        page.locator("#scrubber").fill("0")
        wait_until(lambda: page.evaluate("window.replayStats.t") < began + 1, timeout=10, what="back at the start")
        page.select_option("#speed", speed)
        page.click("#play")
        rate = page.evaluate("""async () => {
            await new Promise((r) => setTimeout(r, 300));
            const t0 = window.replayStats.t, w0 = performance.now();
            await new Promise((r) => setTimeout(r, 1200));
            return (window.replayStats.t - t0) / ((performance.now() - w0) / 1000);
        }""")
        page.click("#play")
        return rate

    slow, fast = pace("1"), pace("4")
    assert 0.6 < slow < 1.4 and 2.5 < fast / slow < 6, (slow, fast)


def test_an_estop_keeps_the_seconds_before_it_and_exports_as_mcap(page, replay_stack):
    stack = replay_stack
    login(page, stack, "olga", next_path="/history/incidents/")
    time.sleep(max(0.0, BEFORE_S + 1 - (time.time() - stack.started_at)))  # the ring holds the seconds before
    assert _post(page, stack, "/api/robot/estop/").ok
    pressed = time.time()
    try:
        def estop_incident():
            found = [i for i in page.request.get(f"{stack.url}/api/history/incidents/").json()["incidents"]
                     if i["kind"] == "estop"]
            return found[0] if found and found[0]["complete"] else None

        incident = wait_until(estop_incident, timeout=AFTER_S + 15, what="a captured E-STOP incident")
    finally:
        assert _post(page, stack, "/api/robot/estop/release/", {"confirm": True}).ok
    assert incident["by"] == "olga" and abs(incident["t"] - pressed) < 2

    code = (f"from history.models import CameraFrame\nprint(CameraFrame.objects.filter(incident_id={incident['id']}, "
            f"t__lt={incident['t']}).count())")
    before = int(stack.manage("shell", "-c", code).strip().splitlines()[-1])
    assert before >= 4 * BEFORE_S, f"only {before} frames kept in the {BEFORE_S} s before the E-STOP"

    page.goto(f"{stack.url}/history/incidents/")
    row = page.locator(f"tr[data-incident='{incident['id']}']")
    expect(row).to_contain_text("E-STOP")
    expect(row.locator("img.incident-thumb")).to_be_visible()
    assert row.locator("img.incident-thumb").evaluate("img => img.naturalWidth") > 0
    row.get_by_role("link", name="Replay").click()
    expect(page.locator("#replay-banner")).to_contain_text("REPLAY")
    expect(page.locator("#replay-frame")).not_to_have_attribute("data-t", "")

    data = page.request.get(f"{stack.url}{incident['mcap']}").body()
    reader = make_reader(io.BytesIO(data))
    times: dict[str, list[float]] = {}
    for _, channel, message in reader.iter_messages(log_time_order=True):
        times.setdefault(channel.topic, []).append(message.log_time / 1e9)
    assert {"/camera", "/pose", "/robot_pose"} <= set(times)
    for topic in ("/camera", "/pose"):
        assert times[topic][0] - incident["start"] < 1.0 and incident["end"] - times[topic][-1] < 1.0, topic
        assert all(incident["start"] <= t <= incident["end"] for t in times[topic])


def test_an_operator_marks_this_moment(page, replay_stack):
    stack = replay_stack
    login(page, stack, "otto", next_path="/history/incidents/")
    page.fill("#mark-note", "a child ran in front")
    page.click("#mark")
    row = page.locator("tr[data-kind='manual']").first
    expect(row).to_contain_text("a child ran in front")
    expect(row).to_contain_text("otto")
    expect(row.get_by_role("link", name="MCAP")).to_be_visible()
