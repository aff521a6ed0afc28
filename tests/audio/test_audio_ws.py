"""/ws/audio/ against the simulator through the real link: microphone chunks out as binary
frames over one upstream subscription, push-to-talk in, one talker, viewers refused,
quiet talkers and E-STOP cut, bad audio refused before it reaches the robot."""

from __future__ import annotations

import asyncio

import pytest

from robot import interface as ri
from robot.models import AuditEntry
from simulator.nodes.audiovisual import dominant_hz, tone
from tests.audio.support import CHUNK, TALK, audio_socket, kind, talk_tone
from tests.helpers import async_wait_until

pytestmark = pytest.mark.django_db(transaction=True)
MIC = ri.topic("audio").name


async def test_listening_relays_the_robot_microphone_as_binary_frames(link, sim, operator):
    ears = await audio_socket(operator)
    await ears.send({"type": "listen", "on": True})
    fmt = await ears.text(kind("format"))
    assert (fmt["coding_format"], fmt["sample_rate"], fmt["channels"]) == ("wave", 16000, 1)
    await ears.text(kind("listening", on=True))
    await ears.chunk_count(25)
    assert all(len(c) == 640 for c in ears.chunks)
    assert dominant_hz(b"".join(ears.chunks), 16000) == pytest.approx(440, abs=5)
    # in order, none missing: the simulator's phase-continuous tone from wherever listening began
    heard = b"".join(ears.chunks)
    mic = sim.robot.av_node.mic
    first = next(k for k in range(mic.published + 1) if tone(440, k * CHUNK, CHUNK, 16000) == ears.chunks[0])
    assert heard == tone(440, first * CHUNK, len(heard) // 2, 16000)
    await ears.send({"type": "listen", "on": False})
    await ears.text(kind("listening", on=False))
    await async_wait_until(lambda: sim.subscription_count(MIC) == 0, what="microphone unsubscribed")
    entry = await AuditEntry.objects.filter(action="audio.listen").alast()
    assert entry.username == "otto" and entry.params["from"] < entry.params["until"]
    await ears.close()


async def test_many_listeners_share_one_upstream_subscription(link, sim, operator, admin_user):
    sockets = [await audio_socket(operator if i % 2 else admin_user) for i in range(6)]
    for ears in sockets:
        await ears.send({"type": "listen", "on": True})
    for ears in sockets:
        await ears.chunk_count(5)
    assert sim.subscription_count(MIC) == 1
    for ears in sockets[:-1]:
        await ears.close()
    assert sim.subscription_count(MIC) == 1  # the last listener still hears
    await sockets[-1].chunk_count(len(sockets[-1].chunks) + 3)
    await sockets[-1].close()  # a disconnect gives the lease back too
    await async_wait_until(lambda: sim.subscription_count(MIC) == 0, what="microphone unsubscribed")
    assert await AuditEntry.objects.filter(action="audio.listen", params__reason="disconnect").acount() == 6


async def test_viewers_may_neither_listen_nor_talk(link, sim, viewer):
    from tests.helpers import ws_communicator

    ws = ws_communicator(viewer, "/ws/audio/")
    assert (await ws.connect())[0]
    hello = await ws.receive_json_from(timeout=5)
    assert hello["type"] == "hello" and not hello["can_listen"] and not hello["can_talk"]
    for request in ({"type": "listen", "on": True}, TALK):
        await ws.send_json_to(request)
        assert (await ws.receive_json_from(timeout=5))["code"] == "forbidden"
    await ws.send_to(bytes_data=tone(440, 0, CHUNK, 16000))
    assert (await ws.receive_json_from(timeout=5))["code"] == "not_talking"
    assert sim.subscription_count(MIC) == 0 and not sim.robot.av_node.speaker.chunks
    await ws.disconnect(timeout=5)


async def test_talk_reaches_the_robot_speakers_with_its_format_declared(link, sim, operator, admin_user, viewer):
    mouth, other, watcher = await audio_socket(operator), await audio_socket(admin_user), await audio_socket(viewer)
    await mouth.send(TALK)
    await mouth.text(kind("talking", on=True))
    assert (await other.text(kind("talker", holder="otto")))["you"] is False
    assert (await watcher.text(kind("talker", holder="otto")))["you"] is False  # viewers see who talks too
    await talk_tone(mouth, 1000, 0.6)
    await async_wait_until(lambda: len(sim.robot.av_node.speaker.chunks) == 30, what="30 chunks at the robot")
    assert sim.robot.av_node.speaker.info == ri.speaker_info()
    assert sim.robot.av_node.speaker.dominant_hz() == pytest.approx(1000, abs=5)
    await mouth.send({"type": "talk", "on": False})
    await mouth.text(kind("talking", on=False, reason="stop"))
    await other.text(kind("talker", holder=None))
    await watcher.text(kind("talker", holder=None))
    await watcher.close()
    entry = await AuditEntry.objects.filter(action="audio.talk").alast()
    assert entry.username == "otto" and entry.params["audio_s"] == pytest.approx(0.6)
    await mouth.close()
    await other.close()


async def test_one_talker_at_a_time(link, sim, operator, admin_user):
    mouth, other = await audio_socket(operator), await audio_socket(admin_user)
    await mouth.send(TALK)
    await mouth.text(kind("talking", on=True))
    await other.send(TALK)
    refusal = await other.text(kind("error"))
    assert refusal["code"] == "busy" and "otto" in refusal["message"]
    await other.ws.send_to(bytes_data=tone(440, 0, CHUNK, 16000))
    assert (await other.text(kind("error")))["code"] == "not_talking"
    await mouth.close()  # a talker who disconnects frees the lock at once
    await other.text(kind("talker", holder=None, reason="disconnect"))
    await other.send(TALK)
    await other.text(kind("talking", on=True))
    await other.close()
    assert await AuditEntry.objects.filter(action="audio.talk", params__reason="disconnect").acount() == 2


async def test_a_talker_who_goes_quiet_is_cut(link, sim, operator, settings):
    settings.AUDIO_TALK_QUIET_S = 0.3
    mouth = await audio_socket(operator)
    await mouth.send(TALK)
    await mouth.text(kind("talking", on=True))
    await talk_tone(mouth, 440, 0.2)
    cut = await mouth.text(kind("talking", on=False))
    assert cut["reason"] == "quiet"
    await mouth.close()


async def test_a_talk_whose_audio_never_comes_is_cut(link, sim, operator, admin_user, settings):
    settings.AUDIO_TALK_QUIET_S = 0.3
    mouth, other = await audio_socket(operator), await audio_socket(admin_user)
    await mouth.send(TALK)
    await mouth.text(kind("talking", on=True))
    cut = await mouth.text(kind("talking", on=False), timeout=5)
    assert cut["reason"] == "quiet"
    await other.text(kind("talker", holder=None, reason="quiet"))
    await mouth.close()
    await other.close()


async def test_estop_ends_talking_and_refuses_a_new_talk(link, sim, operator):
    from robot.estop.stop import estop_run

    mouth = await audio_socket(operator)
    await mouth.send(TALK)
    await mouth.text(kind("talking", on=True))
    await talk_tone(mouth, 440, 0.1)
    report = await estop_run(user=operator, source="test")
    assert any(s.step == "talk" and "otto stopped talking" in s.detail for s in report.steps)
    await mouth.text(kind("talking", on=False, reason="estop"))
    await mouth.send(TALK)
    assert (await mouth.text(kind("error")))["code"] == "estop"
    await mouth.close()


@pytest.mark.parametrize("declared, problem", [
    ({"format": "F32LE"}, "format"), ({"rate": 48000}, "rate"), ({"channels": 2}, "channels"),
])
async def test_a_talk_in_another_format_is_refused(link, sim, operator, declared, problem):
    mouth = await audio_socket(operator)
    await mouth.send({**TALK, **declared})
    refusal = await mouth.text(kind("error"))
    assert refusal["code"] == "invalid" and problem in refusal["message"]
    await mouth.close()


async def test_bad_chunks_are_refused_and_never_reach_the_robot(link, sim, operator):
    mouth = await audio_socket(operator)
    await mouth.send(TALK)
    await mouth.text(kind("talking", on=True))
    for bad, says in ((b"\x00" * 641, "whole"), (b"\x00" * 200, "20-100 ms"), (b"\x00" * 4000, "20-100 ms")):
        await mouth.ws.send_to(bytes_data=bad)
        refusal = await mouth.text(kind("error"))
        assert refusal["code"] == "invalid" and says in refusal["message"]
    for _ in range(12):  # 1.2 s of audio at once: faster than real time
        await mouth.ws.send_to(bytes_data=tone(440, 0, 1600, 16000))
    refusal = await mouth.text(kind("error"))
    assert "faster than real time" in refusal["message"]
    await asyncio.sleep(0.05)
    chunks = sim.robot.av_node.speaker.chunks
    assert all(len(c.pcm) == 3200 for c in chunks) and len(chunks) < 12
    await mouth.close()


async def test_after_listen_off_the_microphone_stays_off(link, sim, operator):
    """A renewal that was waiting when the operator stopped listening used to take the microphone
    again a second later, for about 6 s (against a real rosbridge)."""
    from robot.audio import session

    ears = await audio_socket(operator)
    await ears.send({"type": "listen", "on": True})
    await ears.text(kind("listening", on=True))
    await asyncio.sleep(session.RENEW_S * 1.5)  # a renewal done, the next one waiting
    await ears.send({"type": "listen", "on": False})
    await ears.text(kind("listening", on=False))
    await async_wait_until(lambda: sim.subscription_count(MIC) == 0, what="microphone unsubscribed")
    for _ in range(100):  # 10 s: several renewal periods and leases
        await asyncio.sleep(0.1)
        assert sim.subscription_count(MIC) == 0
    await ears.close()
