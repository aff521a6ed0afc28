"""Replay and the black box through the real product: an embedded stack (simulator + Daphne with the
recorder, the camera recorder and the black box) and headless Chromium.

A day of history is written into the stack's database beside what it records live, the way the
recorder writes it (``write_rows``; ``write_frames`` for the camera: a frame file and its row): the
pose at 2 Hz, odometry and goal status at 1 Hz, the plan, diagnostics, battery, state changes, log
lines and a camera frame every half second (a small JPEG: this figure is about seeking, not bytes).

- ``replay_seek_p99_ms``: 60 jumps to random moments of that day on the Replay page (the scrubber's
  input event until the page shows that moment: state and window fetched, the map drawn, the camera
  frame of that moment loaded).
- ``replay_play_fps``: page updates per second while playing at 4x (``replay_play_camera_fps``: new
  camera frames shown per second, 2 recorded per second x 4).
- ``camera_storage_mb_per_hour``: the frames the camera recorder stored from the simulator's camera
  at the default 2 fps, 320x240, quality 60, per hour (the simulator's picture; a real camera's
  JPEGs are larger: see the README).
- ``incident_capture_lost_msgs``: a marked moment once the stack (with the default recording
  policies) has run longer than the minute before it; when its 90 s have passed, the odometry
  messages missing from it (gaps in header.seq,
  which the simulator numbers like roscpp, and from the window's edges at its 10 Hz).
- ``incident_export_s``: that 90 s incident (every message of the black box's topics, the camera at
  the simulator's full 8 fps) as one MCAP over HTTP.

Run: .venv/bin/python bench/replay.py   (about three minutes; the machine may be shared)
"""

from __future__ import annotations

import io
import json
import os
import random
import statistics
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.browser.support import CHROMIUM, CHROMIUM_ARGS  # noqa: E402
from tests.browser.support import login as page_login  # noqa: E402
from tests.stack import PYTHON, Stack  # noqa: E402

# Hours of seeded history (24 by default; fewer for a quick check of the bench itself).
DAY_S = float(os.environ.get("BENCH_REPLAY_HOURS", "24")) * 3600.0
SEEKS = 60

SEED = r"""
import io, json, math, sys, time
from PIL import Image
from history.frames import write_frames
from history.storage import write_rows
from robot import interface as ri

end, day = float(sys.argv[-2]), float(sys.argv[-1]); start = end - day
T = {k: ri.topic(k) for k in ("robot_pose", "odom", "move_base_status", "plan", "diagnostics", "battery_soc",
                              "state_change", "rosout")}
def row(key, t, msg):
    return (T[key].name, T[key].type, t, json.dumps(msg))
def pose(t):
    a = t / 60.0
    return {"position": {"x": 5 * math.cos(a), "y": 5 * math.sin(a), "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(a / 2), "w": math.cos(a / 2)}}
buf = io.BytesIO(); Image.new("RGB", (320, 240), (90, 120, 160)).save(buf, "JPEG", quality=60); jpeg = buf.getvalue()
batch, frames = [], []
def flush(force=False):
    global batch, frames
    if len(batch) >= 20000 or force:
        write_rows(batch); batch = []
    if len(frames) >= 5000 or force:
        write_frames(frames); frames = []
states = ["idle", "wandering_emotional", "navigation_planning", "idle", "sleepy"]
for i in range(int(day * 2)):
    t = start + i / 2
    batch.append(row("robot_pose", t, pose(t)))
    frames.append((t + 0.01, jpeg, None))
    if i % 2 == 0:
        p = pose(t)
        batch.append(row("odom", t, {"header": {"seq": i, "stamp": {"secs": int(t), "nsecs": 0}, "frame_id": "odom"},
                                     "child_frame_id": "base_link", "pose": {"pose": p},
                                     "twist": {"twist": {"linear": {"x": 0.3, "y": 0, "z": 0},
                                               "angular": {"x": 0, "y": 0, "z": 0.1}}}}))
        batch.append(row("move_base_status", t, {"status_list": [{"status": 1, "text": ""}]}))
    if i % 4 == 0:
        batch.append(row("plan", t, {"poses": [{"pose": pose(t + k)} for k in range(0, 20, 5)]}))
    if i % 10 == 0:
        batch.append(row("diagnostics", t, {"status": [{"name": "battery", "level": 0, "message": "ok"}]}))
    if i % 20 == 0:
        batch.append(row("battery_soc", t, {"data": 1 - (i % 7200) / 7200}))
    if i % 600 == 0:
        state = states[i // 600 % 5]
        batch.append(row("state_change", t, {"event": "", "from_system_state": "", "to_system_state": state}))
    if i % 17 == 0:
        batch.append(row("rosout", t, {"level": 2, "name": "/bench", "msg": f"line {i}"}))
    flush()
flush(True)
print("seeded", file=sys.stderr)
"""

LOST = """
import json
from history.models import Incident, Sample
from robot import interface as ri
i = Incident.objects.get(pk=PK)
rows = Sample.objects.filter(topic=ri.topic("odom").name, received_at__gte=utc(i.start), received_at__lte=utc(i.end))
seqs = sorted(d["header"]["seq"] for d in rows.values_list("data", flat=True))
stamps = sorted(a.timestamp() for a in rows.values_list("received_at", flat=True))
print(json.dumps({"seqs": seqs, "first": stamps[0], "last": stamps[-1], "start": i.start, "end": i.end,
                  "complete": i.complete}))
"""

FRAMES = """
from django.db.models import Sum, Count
from history.models import CameraFrame
live = CameraFrame.objects.filter(t__gt=AFTER, incident__isnull=True)
print(list(live.aggregate(n=Count("id"), b=Sum("size")).values()))
"""


def shell(stack: Stack, code: str) -> str:
    return stack.manage("shell", "-c", code).strip().splitlines()[-1]


def post(stack: Stack, cookie: str, path: str, body: dict) -> dict:
    token = next(p.split("=", 1)[1] for p in cookie.split("; ") if p.startswith("csrftoken="))
    req = urllib.request.Request(f"{stack.url}{path}", data=json.dumps(body).encode(), method="POST", headers={
        "Cookie": cookie, "X-CSRFToken": token, "Content-Type": "application/json", "Referer": stack.url})
    with urllib.request.urlopen(req, timeout=30) as res:
        return json.loads(res.read())


def seek_and_play(stack: Stack, start: float, end: float) -> dict[str, float]:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_context(viewport={"width": 1366, "height": 800}).new_page()
        page.set_default_timeout(30_000)
        page_login(page, stack, "vera", next_path="/history/")
        page.goto(f"{stack.url}/history/replay/?start={start}&end={end}&t={start + 600}")
        deadline = time.monotonic() + 60
        while not page.evaluate("() => window.replayStats && window.replayStats.seeks > 0"):
            assert time.monotonic() < deadline, "the Replay page never showed a moment"
            time.sleep(0.1)
        rng = random.Random(7)
        times = []
        for _ in range(SEEKS):
            value = rng.randrange(0, 1001)
            times.append(page.evaluate("""async (value) => {
                const scrubber = document.getElementById('scrubber'), img = document.getElementById('replay-frame');
                const seeks = window.replayStats.seeks, t0 = performance.now();
                scrubber.value = String(value);
                scrubber.dispatchEvent(new Event('input'));
                while (window.replayStats.seeks === seeks || !img.complete) await new Promise(requestAnimationFrame);
                return performance.now() - t0;
            }""", value))
        page.select_option("#speed", "4")
        page.click("#play")
        played = page.evaluate("""async () => {
            await new Promise((r) => setTimeout(r, 500));
            const r0 = window.replayStats.renders, f0 = window.replayStats.frames, w0 = performance.now();
            await new Promise((r) => setTimeout(r, 5000));
            const s = (performance.now() - w0) / 1000;
            return [(window.replayStats.renders - r0) / s, (window.replayStats.frames - f0) / s];
        }""")
        browser.close()
    times.sort()
    return {"replay_seek_p50_ms": statistics.median(times), "replay_seek_p99_ms": times[int(len(times) * 0.99) - 1],
            "replay_play_fps": played[0], "replay_play_camera_fps": played[1]}


def main() -> None:
    env = {"INCIDENT_BEFORE_S": "60", "INCIDENT_AFTER_S": "30", "LOG_LEVEL": "WARNING"}
    with Stack(sim_args=("--startup-s", "0.5"), env=env) as stack:
        stack.wait_robot_online()
        stack.manage("shell", "-c", "from history.defaults import ensure_default_policies; ensure_default_policies()")
        up = time.time()
        seed_end = up - 3600.0  # the seeded day ends an hour before the live recording begins
        seeding = time.perf_counter()
        subprocess.run([PYTHON, "-c", "import django; django.setup(); import sys; exec(sys.argv[1])", SEED,
                        str(seed_end), str(DAY_S)], cwd=ROOT, env=stack.env, check=True, capture_output=True, text=True,
                       timeout=900)
        print(f"# a day of history written in {time.perf_counter() - seeding:.0f} s", file=sys.stderr)
        figures = seek_and_play(stack, seed_end - DAY_S, seed_end)

        time.sleep(max(0.0, 65 - (time.time() - up)))  # the ring holds the minute before the mark
        n, size = json.loads(shell(stack, f"AFTER = {up}\n" + FRAMES))
        span = time.time() - up
        figures["camera_storage_mb_per_hour"] = (size or 0) / span * 3600 / 1e6
        figures["camera_frames_per_s"] = (n or 0) / span
        cookie = stack.login_cookie("otto")
        incident = post(stack, cookie, "/api/history/incidents/", {"note": "bench"})
        time.sleep(incident["end"] - time.time() + 3)
        capture = json.loads(shell(stack, f"from history.storage import utc\nPK = {incident['id']}\n" + LOST))
        seqs = capture["seqs"]
        gaps = (seqs[-1] - seqs[0] + 1) - len(set(seqs))
        edges = round((capture["first"] - capture["start"]) * 10) + round((capture["end"] - capture["last"]) * 10)
        figures["incident_capture_lost_msgs"] = gaps + max(0, edges - 2)  # up to one 10 Hz period at each edge

        started = time.perf_counter()
        req = urllib.request.Request(f"{stack.url}{incident['mcap']}", headers={"Cookie": cookie})
        with urllib.request.urlopen(req, timeout=60) as res:
            data = res.read()
        figures["incident_export_s"] = time.perf_counter() - started
        from mcap.reader import make_reader

        summary = make_reader(io.BytesIO(data)).get_summary()
        counts = {summary.channels[cid].topic: n for cid, n in summary.statistics.channel_message_counts.items()}
        figures["incident_export_camera_frames"] = counts.get("/camera", 0)
        figures["incident_export_mb"] = len(data) / 1e6
    for name, value in figures.items():
        print(f"{name}: {value:.2f}" if isinstance(value, float) else f"{name}: {value}")


if __name__ == "__main__":
    main()
