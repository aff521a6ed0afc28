"""Two-way audio in a real Chromium with fake media devices: holding Talk sends the test's tone
to the simulated robot's speakers, Listen plays the robot's microphone tone through the page's
analyser, and viewers find both disabled."""

from __future__ import annotations

import base64
import re
import threading
import wave

import numpy as np
import pytest
import roslibpy
from playwright.sync_api import expect

from robot import interface as ri
from robot.sim.audio import dominant_hz
from tests.browser.support import CHROMIUM, CHROMIUM_ARGS, fresh_page, login

pytestmark = pytest.mark.browser
TEST_TONE_HZ = 700.0
MIC_TONE_HZ = 440.0  # the simulator's microphone


@pytest.fixture(scope="module")
def media_browser(browser, tmp_path_factory):
    """Chromium whose microphone plays a WAV of TEST_TONE_HZ, permission granted."""
    path = tmp_path_factory.mktemp("audio") / "tone.wav"
    rate = 48000
    t = np.arange(rate * 4) / rate
    samples = (np.sin(2 * np.pi * TEST_TONE_HZ * t) * 0.5 * 32767).astype("<i2")
    with wave.open(str(path), "wb") as out:
        out.setnchannels(1)
        out.setsampwidth(2)
        out.setframerate(rate)
        out.writeframes(samples.tobytes())
    instance = browser.browser_type.launch(executable_path=CHROMIUM, args=[
        *CHROMIUM_ARGS, "--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream",
        f"--use-file-for-fake-audio-capture={path}", "--autoplay-policy=no-user-gesture-required",
    ])
    yield instance
    instance.close()


@pytest.fixture
def media_page(media_browser):
    with fresh_page(media_browser, viewport={"width": 1280, "height": 900}) as page:
        yield page


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
    talk = page.locator("#audio-talk")
    expect(talk).to_be_enabled()
    tap = SpeakerTap(stack)
    try:
        talk.hover()
        page.mouse.down()
        expect(page.locator("#audio-talker")).to_have_text("You are talking")
        deadline_ok = False
        for _ in range(100):
            if tap.seconds() >= 1.0:
                deadline_ok = True
                break
            page.wait_for_timeout(50)
        page.mouse.up()
        assert deadline_ok, f"only {tap.seconds():.2f} s of audio reached the robot"
        expect(page.locator("#audio-talker")).to_have_text("Nobody is talking")
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
    # The analyser's strongest bin is the simulator's tone (bins are 48000/2048 ≈ 23 Hz wide).
    page.wait_for_function(
        f"() => Math.abs(Number(document.getElementById('audio-level').dataset.hz) - {MIC_TONE_HZ}) < 30")
    assert page.locator("#audio-level").evaluate("el => el.value") > 0.05
    listen.click()
    expect(listen).to_have_text("Listen")


def test_viewers_find_talk_and_listen_disabled_with_the_reason(page, stack):
    login(page, stack, "vera", next_path="/drive/")
    expect(page.locator("#audio-status")).to_have_text("Connected")
    expect(page.locator("#audio-listen")).to_be_disabled()
    expect(page.locator("#audio-talk")).to_be_disabled()
    expect(page.locator("#audio-problem")).to_contain_text("may not listen or talk")


def test_a_browser_without_a_usable_microphone_says_why(page, stack):
    """Headless Chromium without fake devices has no microphone it may use: holding Talk
    explains that instead of failing silently, and nothing reaches the robot."""
    login(page, stack, "olga", next_path="/drive/")
    talk = page.locator("#audio-talk")
    expect(talk).to_be_enabled()
    talk.hover()
    page.mouse.down()
    expect(page.locator("#audio-problem")).to_contain_text(re.compile("permission denied|No microphone found"))
    page.mouse.up()
    expect(page.locator("#audio-talker")).to_have_text("Nobody is talking")
