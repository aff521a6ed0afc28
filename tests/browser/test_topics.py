"""The Topics page in a real browser: it lists /rosout, shows its messages live, plots a field,
watches again after its websocket reconnects, and redraws a fast topic at a readable rate."""

from __future__ import annotations

import json
import re

import pytest
from playwright.sync_api import expect

from robot import interface as ri
from tests.browser.support import login

pytestmark = pytest.mark.browser

ROSOUT = ri.topic("rosout").name
ODOM = ri.topic("odom").name
TF = ri.topic("tf").name  # 25 Hz from the simulator, sent to pages at up to 20 Hz
# Pixels of the first plotted series' colour (#1f6feb) on the plot's canvas.
SERIES_PIXELS = """() => {
    const canvas = document.querySelector('#topic-plot canvas');
    if (!canvas) return 0;
    const data = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
    let n = 0;
    for (let i = 0; i < data.length; i += 4) {
        if (Math.abs(data[i] - 31) < 40 && Math.abs(data[i + 1] - 111) < 40 && Math.abs(data[i + 2] - 235) < 40
            && data[i + 3] > 0) n++;
    }
    return n;
}"""


def test_the_topics_page_lists_rosout_and_shows_its_messages_live(stack, page):
    login(page, stack, "vera", next_path="/topics/")
    row = page.locator(f"tr.topic-row[data-topic='{ROSOUT}']")
    expect(row).to_be_visible(timeout=20_000)
    expect(row).to_contain_text("rosgraph_msgs/Log")
    page.fill("#topics-search", "rosgraph")
    expect(page.locator("tr.topic-row")).to_have_count(1)
    row.locator(".topic-open").click()
    expect(page.locator("#topic-name")).to_have_text(ROSOUT)
    meta = page.locator("#topic-meta")
    expect(meta).to_contain_text("received", timeout=20_000)
    expect(page.locator("#topic-message .key", has_text="msg")).to_be_visible()
    first = meta.inner_text()
    # The simulator logs every few seconds: a newer message replaces the one shown.
    expect(meta).not_to_have_text(first, timeout=30_000)
    # A viewer may watch but not record.
    expect(page.locator("#topic-record")).to_be_disabled()


def test_clicking_a_number_plots_it_live(stack, page):
    login(page, stack, "vera", next_path=f"/topics/?topic={ODOM}")
    expect(page.locator("#topic-meta")).to_contain_text("received", timeout=20_000)
    page.locator("#topic-pause").click()  # the tree holds still while we open it; the plot keeps going
    for part in ("header", "stamp"):
        page.locator("#topic-message summary", has=page.locator(".key", has_text=part)).first.click()
    page.locator("#topic-message .row", has=page.locator(".key", has_text="secs")).locator(".num").first.click()
    expect(page.locator("#topic-plot canvas").first).to_be_visible()
    expect(page.locator("#topic-plot-fields")).to_have_text("header.stamp.secs (s)")  # with its unit
    page.wait_for_function(f"({SERIES_PIXELS})() > 20", timeout=15_000)
    # The server's unit table, as the plot applies it: battery in % (scaled), speeds in m/s, unknown none.
    units = page.evaluate("""async () => {
        const { unitOf } = await import('/static/js/plotaxes.js');
        const rules = JSON.parse(document.getElementById('topics-config').textContent).units;
        return [unitOf(rules, '/RosAria/battery_state_of_charge', 'data'),
                unitOf(rules, '/odom', 'twist.twist.linear.x'), unitOf(rules, '/odom', 'child_frame_id')];
    }""")
    assert units == [{"unit": "%", "scale": 100}, {"unit": "m/s", "scale": 1}, None], units


UNKNOWN = "/no_such_topic_here"


class LiveSockets:
    """The page's live websockets, each passed through to the real server and recorded: what the
    page sent on each connection, and a way to drop the current one as a network failure would."""

    def __init__(self, page) -> None:
        self.connections: list[tuple[object, object, list[dict]]] = []
        page.route_web_socket(re.compile(r"/ws/live/"), self._route)

    def _route(self, ws) -> None:
        server = ws.connect_to_server()
        sent: list[dict] = []

        def from_page(message) -> None:
            sent.append(json.loads(message))
            server.send(message)

        ws.on_message(from_page)
        self.connections.append((ws, server, sent))

    def sent(self, index: int = -1) -> list[dict]:
        return list(self.connections[index][2])

    def drop(self, page) -> None:
        before = len(self.connections)
        ws, server, _ = self.connections[-1]
        server.close()
        ws.close(code=1006)
        page.wait_for_function("() => !document.body.classList.contains('socket-down')", timeout=15_000)
        assert len(self.connections) == before + 1


def _topic_watches(sent: list[dict]) -> list[str]:
    return [m["topic"] for m in sent if m.get("action") == "watch_topic"]


def test_after_a_reconnect_it_watches_again_only_the_topics_the_server_accepted(stack, page):
    sockets = LiveSockets(page)
    login(page, stack, "vera", next_path=f"/topics/?topic={UNKNOWN}")
    meta = page.locator("#topic-meta")
    expect(meta).to_contain_text(f"Cannot watch {UNKNOWN}", timeout=15_000)
    assert _topic_watches(sockets.sent()) == [UNKNOWN]
    sockets.drop(page)
    expect(meta).to_contain_text(f"Cannot watch {UNKNOWN}")  # the refusal stays on screen
    # Opening another topic is sent after whatever the page sent on connecting: all of it is in.
    page.locator(f"tr.topic-row[data-topic='{ROSOUT}'] .topic-open").click()
    expect(meta).to_contain_text("received", timeout=20_000)
    assert _topic_watches(sockets.sent()) == [ROSOUT]
    first = meta.inner_text()
    sockets.drop(page)
    for _ in range(50):  # what the page sends on connecting reaches the recorder a moment later
        if _topic_watches(sockets.sent()):
            break
        page.wait_for_timeout(100)
    assert _topic_watches(sockets.sent()) == [ROSOUT]
    expect(meta).not_to_have_text(first, timeout=30_000)  # and its messages come again


# Counts, from now on, the frames of one topic the page receives and the redraws of its message view.
COUNT_REDRAWS = """(key) => {
    window.redraws = 0;
    window.framesIn = 0;
    new MutationObserver((records) => { window.redraws += records.length; })
        .observe(document.getElementById('topic-message'), {childList: true});
    window.countFrames = (data) => { if (data.includes(JSON.stringify(key))) window.framesIn++; };
}"""
# Installed before the page's scripts: every websocket message goes past window.countFrames.
TAP_SOCKETS = """(() => {
    const Original = window.WebSocket;
    window.WebSocket = class extends Original {
        constructor(...args) {
            super(...args);
            this.addEventListener('message', (ev) => window.countFrames?.(String(ev.data)));
        }
    };
})()"""


def test_a_fast_topic_is_redrawn_a_few_times_a_second(stack, page):
    page.add_init_script(TAP_SOCKETS)
    login(page, stack, "vera", next_path=f"/topics/?topic={TF}")
    expect(page.locator("#topic-meta")).to_contain_text("received", timeout=20_000)
    page.evaluate(COUNT_REDRAWS, f"topic:{TF}")
    window_s = 3
    page.wait_for_timeout(window_s * 1000)
    redraws, frames = page.evaluate("[window.redraws, window.framesIn]")
    assert frames >= 3 * window_s * 4, frames  # it comes far faster than a person reads
    assert window_s <= redraws <= window_s * 5, (redraws, frames)  # yet is redrawn at most about 4 times a second


VOLTAGE = ri.topic("battery_voltage").name


def _policy(page, stack, topic: str) -> dict | None:
    policies = page.request.get(f"{stack.url}/api/history/topics/").json()["topics"]
    return next((p for p in policies if p["topic"] == topic), None)


def _set_policy(page, stack, item: dict) -> None:
    token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
    answer = page.request.patch(f"{stack.url}/api/history/topics/", data={"topics": [item]},
                                headers={"X-CSRFToken": token})
    assert answer.ok, answer.text()


def test_record_shows_the_current_policy_and_asks_before_replacing_it(stack, page):
    login(page, stack, "ada", next_path="/topics/")
    before = _policy(page, stack, VOLTAGE)
    _set_policy(page, stack, {"topic": VOLTAGE, "msg_type": "std_msgs/Float64", "mode": "periodic",
                              "interval_s": 1.0, "retention_s": 2 * 86400.0})
    try:
        page.locator(f"tr.topic-row[data-topic='{VOLTAGE}'] .topic-open").click()
        expect(page.locator("#topic-policy")).to_have_text("Recorded every 1 s, kept 2 d.")
        asked: list[str] = []

        def answer(accept: bool):
            def handle(dialog) -> None:
                asked.append(dialog.message)
                dialog.accept() if accept else dialog.dismiss()
            return handle

        # Said no: the admin's policy stays as it was.
        page.once("dialog", answer(False))
        page.click("#topic-record")
        expect(page.locator(".toast, .notice", has_text="kept as it was").first).to_be_visible()
        assert asked == [f"{VOLTAGE}: recorded every 1 s, kept 2 d. Record every message instead?"], asked
        policy = _policy(page, stack, VOLTAGE)
        assert policy is not None and (policy["mode"], policy["interval_s"]) == ("periodic", 1.0), policy
        # Said yes: every message, and the card says so.
        page.once("dialog", answer(True))
        page.click("#topic-record")
        expect(page.locator("#topic-policy")).to_have_text("Recorded every message, kept 2 d.")
        assert len(asked) == 2
        assert _policy(page, stack, VOLTAGE)["mode"] == "every"
        # Already so: nothing to ask.
        page.click("#topic-record")
        expect(page.locator(".toast, .notice", has_text="already recorded every message").first).to_be_visible()
        assert len(asked) == 2
    finally:
        kept = ("topic", "msg_type", "mode", "interval_s", "retention_s")
        _set_policy(page, stack, {k: before[k] for k in kept} if before else {"topic": VOLTAGE, "mode": "off"})
