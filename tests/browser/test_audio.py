"""Two-way audio in a real Chromium with fake media devices: holding Talk sends the test's tone
to the simulated robot's speakers, Listen plays the robot's microphone tone (raw PCM or mp3)
through the page's analyser, on the Drive page and the dashboard; viewers find both disabled;
plain HTTP, a denied permission and a missing microphone are each explained."""

from __future__ import annotations

import base64
import threading
import types
import wave

import numpy as np
import pytest
import roslibpy
from playwright.sync_api import expect

from robot import interface as ri
from simulator.nodes.audiovisual import dominant_hz
from tests.browser.support import CHROMIUM, CHROMIUM_ARGS, FULL_CHROMIUM, FULL_CHROMIUM_ARGS, fresh_page, login
from tests.stack import Stack

pytestmark = pytest.mark.browser
TEST_TONE_HZ = 700.0
MIC_TONE_HZ = 440.0  # the simulator's microphone
# A name the test browsers resolve to 127.0.0.1: not localhost, so plain HTTP there is what
# browsers call an insecure origin (no microphone), as on a robot's LAN address.
STATION_HOST = "station.test"
# Tests on mp3_stack start its processes first: allow for a loaded machine.
SLOW_SETUP = pytest.mark.timeout(360)


@pytest.fixture(scope="module")
def tone_wav(tmp_path_factory):
    path = tmp_path_factory.mktemp("audio") / "tone.wav"
    rate = 48000
    t = np.arange(rate * 4) / rate
    samples = (np.sin(2 * np.pi * TEST_TONE_HZ * t) * 0.5 * 32767).astype("<i2")
    with wave.open(str(path), "wb") as out:
        out.setnchannels(1)
        out.setsampwidth(2)
        out.setframerate(rate)
        out.writeframes(samples.tobytes())
    return path


@pytest.fixture(scope="module")
def media_browser(browser, tone_wav):
    """Chromium whose microphone plays a WAV of TEST_TONE_HZ, permission granted."""
    instance = browser.browser_type.launch(executable_path=CHROMIUM, args=[
        *CHROMIUM_ARGS, "--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream",
        f"--use-file-for-fake-audio-capture={tone_wav}", "--autoplay-policy=no-user-gesture-required",
        f"--host-resolver-rules=MAP {STATION_HOST} 127.0.0.1",
    ])
    yield instance
    instance.close()


@pytest.fixture
def media_page(media_browser):
    with fresh_page(media_browser, viewport={"width": 1280, "height": 900}) as page:
        yield page


@pytest.fixture(scope="module")
def mp3_stack(stack):
    """A second simulator and web process: the simulator's microphone sends mp3, and the web
    process also answers to STATION_HOST. It shares the session stack's database (its users)."""
    env = {"ALLOWED_HOSTS": f"127.0.0.1,localhost,[::1],{STATION_HOST}", "DATABASE_URL": stack.env["DATABASE_URL"]}
    with Stack(sim_args=("--mic-coding", "mp3"), env=env, users=False) as running:
        running.wait_robot_online()
        yield running


def hears_mic_tone(page) -> None:
    """Wait until, in one drawn frame, the page's analyser's strongest bin is the simulator's
    tone (bins are 48000/2048 ≈ 23 Hz wide) and the level meter moves."""
    try:
        page.wait_for_function(f"""() => {{
            const meter = document.getElementById('audio-level');
            return Math.abs(Number(meter.dataset.hz) - {MIC_TONE_HZ}) < 30 && meter.value > 0.05;
        }}""")
    except Exception as exc:
        seen = page.evaluate("""() => ({hz: document.getElementById('audio-level').dataset.hz,
            status: document.getElementById('audio-status').textContent,
            listen: document.getElementById('audio-listen').textContent,
            notices: [...document.querySelectorAll('.notice')].map((n) => n.textContent)})""")
        raise AssertionError(f"the page never heard the simulator's tone: {seen}") from exc


def hold_talk(page, tap, seconds: float = 1.0) -> None:
    """Hold Talk until ``seconds`` of audio reached the robot (or 5 s passed), then let go."""
    page.locator("#audio-talk").hover()
    page.mouse.down()
    try:
        expect(page.locator("#audio-talker")).to_have_text("You are talking")
        for _ in range(100):
            if tap.seconds() >= seconds:
                break
            page.wait_for_timeout(50)
    finally:
        page.mouse.up()
    assert tap.seconds() >= seconds, f"only {tap.seconds():.2f} s of audio reached the robot"
    expect(page.locator("#audio-talker")).to_have_text("Nobody is talking")


class SpeakerTap:
    """What reaches the simulated robot's speakers, heard as any ROS node would (roslibpy)."""

    def __init__(self, stack) -> None:
        self.ros = roslibpy.Ros("127.0.0.1", stack.sim_port)
        self.ros.run(timeout=10)
        self.pcm = bytearray()
        self.lock = threading.Lock()
        t = ri.topic("speaker")
        self.topic = roslibpy.Topic(self.ros, t.name, t.type)
        self.topic.subscribe(self._on)

    def _on(self, msg) -> None:
        with self.lock:
            self.pcm += base64.b64decode(msg["data"])

    def seconds(self) -> float:
        with self.lock:
            return len(self.pcm) / 32000

    def close(self) -> None:
        self.topic.unsubscribe()
        self.ros.close()


def test_holding_talk_sends_the_microphone_tone_to_the_robot(media_page, stack):
    page = media_page
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    login(page, stack, "otto", next_path="/drive/")
    expect(page.locator("#audio-talk")).to_be_enabled()
    tap = SpeakerTap(stack)
    try:
        hold_talk(page, tap)
        with tap.lock:
            pcm = bytes(tap.pcm[16000:])  # past the first half second (capture and processing settle)
        assert dominant_hz(pcm, 16000) == pytest.approx(TEST_TONE_HZ, abs=10)
    finally:
        tap.close()
    assert errors == []


def test_listen_plays_the_robot_microphone_through_the_level_meter(media_page, stack):
    page = media_page
    login(page, stack, "olga", next_path="/drive/")
    listen = page.locator("#audio-listen")
    expect(listen).to_be_enabled()
    listen.click()
    expect(listen).to_have_text("Stop listening")
    hears_mic_tone(page)
    listen.click()
    expect(listen).to_have_text("Listen")


@SLOW_SETUP
def test_listen_plays_an_mp3_microphone(media_page, mp3_stack):
    page = media_page
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    login(page, mp3_stack, "olga", next_path="/drive/")
    listen = page.locator("#audio-listen")
    expect(listen).to_be_enabled()
    listen.click()
    expect(listen).to_have_text("Stop listening")
    hears_mic_tone(page)
    expect(page.locator(".notice-error")).to_have_count(0)
    listen.click()
    expect(listen).to_have_text("Listen")
    assert errors == []


def test_the_dashboard_listens_and_talks_with_the_same_card(media_page, stack):
    page = media_page
    login(page, stack, "otto", next_path="/")
    card = page.locator("#audio")
    expect(card.locator("#audio-status")).to_have_text("Connected")
    listen = card.locator("#audio-listen")
    listen.click()
    expect(listen).to_have_text("Stop listening")
    hears_mic_tone(page)
    listen.click()
    expect(listen).to_have_text("Listen")
    tap = SpeakerTap(stack)
    try:
        hold_talk(page, tap, seconds=0.6)
    finally:
        tap.close()


def test_viewers_find_talk_and_listen_disabled_with_the_reason(page, stack):
    login(page, stack, "vera", next_path="/drive/")
    for path in ("/drive/", "/"):
        page.goto(f"{stack.url}{path}")
        expect(page.locator("#audio-status")).to_have_text("Connected")
        expect(page.locator("#audio-listen")).to_be_disabled()
        expect(page.locator("#audio-talk")).to_be_disabled()
        expect(page.locator("#audio-problem")).to_contain_text("may not listen or talk")


@SLOW_SETUP
def test_plain_http_on_a_network_address_explains_why_talk_cannot_work(media_page, mp3_stack):
    """Chromium refuses the microphone to an insecure origin (no navigator.mediaDevices at all):
    the page says why at once and again when Talk is held; nothing reaches the robot. Listening
    needs no microphone and still works."""
    page = media_page
    station = types.SimpleNamespace(url=f"http://{STATION_HOST}:{mp3_stack.web_port}")
    login(page, station, "olga", next_path="/drive/")
    assert page.evaluate("() => window.isSecureContext") is False
    problem = page.locator("#audio-problem")
    expect(problem).to_contain_text("only over HTTPS or on localhost")
    expect(problem).to_contain_text(f"plain HTTP at {STATION_HOST}:{mp3_stack.web_port}")
    page.evaluate("() => { document.getElementById('audio-problem').textContent = ''; }")
    tap = SpeakerTap(mp3_stack)
    try:
        page.locator("#audio-talk").hover()
        page.mouse.down()
        expect(problem).to_contain_text("only over HTTPS or on localhost")
        page.wait_for_timeout(500)
        expect(page.locator("#audio-talker")).to_have_text("Nobody is talking")
        page.mouse.up()
        assert tap.seconds() == 0
    finally:
        tap.close()
    page.locator("#audio-listen").click()
    hears_mic_tone(page)
    page.locator("#audio-listen").click()


@pytest.fixture
def denying_page(browser, tone_wav):
    """Chromium with a (fake) microphone whose permission prompts are all answered no."""
    instance = browser.browser_type.launch(executable_path=FULL_CHROMIUM, args=[
        *FULL_CHROMIUM_ARGS, "--use-fake-device-for-media-stream", f"--use-file-for-fake-audio-capture={tone_wav}",
        "--deny-permission-prompts",
    ])
    try:
        with fresh_page(instance, viewport={"width": 1280, "height": 900}) as page:
            yield page
    finally:
        instance.close()


def talk_is_refused_with(page, stack, reason: str) -> None:
    login(page, stack, "olga", next_path="/drive/")
    expect(page.locator("#audio-talk")).to_be_enabled()
    expect(page.locator("#audio-problem")).to_be_hidden()
    tap = SpeakerTap(stack)
    try:
        page.locator("#audio-talk").hover()
        page.mouse.down()
        expect(page.locator("#audio-problem")).to_contain_text(reason)
        page.mouse.up()
        expect(page.locator("#audio-talker")).to_have_text("Nobody is talking")
        assert tap.seconds() == 0
    finally:
        tap.close()


def test_a_denied_microphone_permission_is_explained(denying_page, stack):
    talk_is_refused_with(denying_page, stack, "Microphone permission denied")


def test_a_computer_without_a_microphone_is_told_so(browser, stack):
    """Permission granted, but this Chromium has no fake devices and the machine no sound card."""
    with fresh_page(browser, viewport={"width": 1280, "height": 900}, permissions=["microphone"]) as page:
        talk_is_refused_with(page, stack, "No microphone found")
