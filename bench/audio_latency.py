"""Two-way audio through the real product: push-to-talk chunk → the robot's speaker topic,
robot microphone chunk → a listening client, gaps in 30 s of talk, the upstream
subscriptions 20 listeners cost, how soon a talker who goes quiet or disconnects is cut, and
what decoding an mp3 microphone costs the link per chunk.

Starts Daphne (embedded default) against a simulator hosted in this process (its microphone
silent, so the bench injects numbered chunks and knows when each left the robot). Python
websocket clients stand in for browsers; times are wall clock on this one machine and exclude
a browser's jitter buffer. Prints ``name: value`` lines.
"""

from __future__ import annotations

import asyncio
import base64
import json
import statistics
import struct
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from websockets.asyncio.client import ClientConnection, connect  # noqa: E402

from bench.teleop_latency import login  # noqa: E402
from robot import interface as ri  # noqa: E402
from robot.audio.mic import decoder_for  # noqa: E402
from simulator.harness import SimThread  # noqa: E402
from simulator.nodes.audiovisual import Microphone, tone  # noqa: E402
from tests.stack import Stack  # noqa: E402

TALK_S = 30.0
CHUNK = 320  # 20 ms at 16 kHz
LISTENERS = 20
MIC_CHUNKS = 500
TALK = {"type": "talk", "on": True, "format": "S16LE", "rate": 16000, "channels": 1}


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


async def audio_socket(stack: Stack, cookie: str) -> ClientConnection:
    ws = await connect(f"ws://127.0.0.1:{stack.web_port}/ws/audio/", origin=stack.url,
                       additional_headers={"Cookie": cookie}, max_size=None)
    hello = json.loads(await ws.recv())
    assert hello["type"] == "hello" and hello["can_talk"], hello
    return ws


async def until(ws: ClientConnection, kind: str) -> dict:
    while True:
        frame = await asyncio.wait_for(ws.recv(), 10)
        if isinstance(frame, str):
            data = json.loads(frame)
            if data["type"] == "error":
                raise SystemExit(f"server refused: {data}")
            if data["type"] == kind:
                return data


async def talk(stack: Stack, sim: SimThread, cookie: str) -> tuple[list[float], float]:
    ws = await audio_socket(stack, cookie)
    await ws.send(json.dumps(TALK))
    await until(ws, "talking")
    sim.call(sim.robot.av_node.speaker.reset)
    sent: list[float] = []
    loop = asyncio.get_running_loop()
    due = loop.time()
    for i in range(round(TALK_S / 0.02)):
        chunk = tone(300, i * CHUNK, CHUNK, 16000)
        sent.append(time.time())
        await ws.send(chunk)
        due += 0.02
        await asyncio.sleep(max(0.0, due - loop.time()))
    deadline = time.monotonic() + 5
    while len(sim.robot.av_node.speaker.chunks) < len(sent) and time.monotonic() < deadline:
        await asyncio.sleep(0.05)
    await ws.send(json.dumps({"type": "talk", "on": False}))
    await ws.close()
    heard = list(sim.robot.av_node.speaker.chunks)
    latencies = [(h.t - s) * 1000 for s, h in zip(sent, heard, strict=False)]
    missing_s = (len(sent) - len(heard)) * 0.02 + sim.robot.av_node.speaker.gap_s(buffer_s=0.06)
    return latencies, 100.0 * missing_s / TALK_S


async def listen(stack: Stack, sim: SimThread, cookie: str) -> tuple[list[float], int]:
    sockets = [await audio_socket(stack, cookie) for _ in range(LISTENERS)]
    for ws in sockets:
        await ws.send(json.dumps({"type": "listen", "on": True}))
        await until(ws, "listening")
    upstream = sim.subscription_count(ri.topic("audio").name)
    published: dict[int, float] = {}
    received: list[tuple[int, float]] = []

    async def read(ws: ClientConnection) -> None:
        async for frame in ws:
            if isinstance(frame, bytes):
                received.append((struct.unpack_from("<I", frame)[0], time.time()))

    readers = [asyncio.ensure_future(read(ws)) for ws in sockets]
    mic = ri.topic("audio").name
    base = tone(440, 0, CHUNK, 16000)
    for i in range(MIC_CHUNKS):
        data = struct.pack("<I", i) + base[4:]
        msg = {"data": base64.b64encode(data).decode()}
        published[i] = time.time()
        sim.call(lambda m=msg: sim.robot.publish_external(mic, m))
        await asyncio.sleep(0.02)
    await asyncio.sleep(1.0)
    for ws in sockets:
        await ws.close()
    for reader in readers:
        reader.cancel()
    latencies = [(t - published[i]) * 1000 for i, t in received if i in published]
    expected = MIC_CHUNKS * LISTENERS
    if len(latencies) < expected:
        print(f"# {expected - len(latencies)} of {expected} microphone chunks never reached a listener")
    return latencies, upstream


CUTS = 5


async def cuts(stack: Stack, cookie: str) -> tuple[list[float], list[float]]:
    """How long after a talker's last chunk the server ends the talk (quiet), and after a
    talker's socket closes another page hears the talk lock free (disconnect)."""
    quiet, gone = [], []
    watcher = await audio_socket(stack, cookie)
    for i in range(CUTS * 2):
        ws = await audio_socket(stack, cookie)
        await ws.send(json.dumps(TALK))
        await until(ws, "talking")
        last = time.monotonic()
        for k in range(10):
            await ws.send(tone(300, k * CHUNK, CHUNK, 16000))
            last = time.monotonic()
            await asyncio.sleep(0.02)
        if i % 2 == 0:
            await until(ws, "talking")
            quiet.append((time.monotonic() - last) * 1000)
            await ws.close()
        else:
            closed = time.monotonic()
            await ws.close()
            while True:
                frame = await until(watcher, "talker")
                if frame["holder"] is None and frame["reason"] == "disconnect":
                    break
            gone.append((time.monotonic() - closed) * 1000)
    await watcher.close()
    return quiet, gone


def mp3_decode_us() -> float:
    """The link's cost to decode one 20 ms chunk of the simulator's mp3 microphone."""
    mic = Microphone(lambda _m: None, lambda: True, coding="mp3")
    chunks = [mic.encode(tone(440, i * CHUNK, CHUNK, 16000)) for i in range(1500)]
    decoder = decoder_for(mic.info())
    start = time.perf_counter()
    for chunk in chunks:
        decoder.feed(chunk)
    return (time.perf_counter() - start) / len(chunks) * 1e6


async def main() -> None:
    with SimThread(port=0, video_port=0, startup_s=0.5, mic_tone_hz=0) as sim:
        with Stack(sim=False, env={"ROSBRIDGE_URL": sim.url}) as stack:
            stack.wait_robot_online()
            cookie = login(stack, "otto")
            talk_ms, gap_pct = await talk(stack, sim, cookie)
            mic_ms, upstream = await listen(stack, sim, cookie)
            quiet_ms, gone_ms = await cuts(stack, cookie)
    print(f"talk_chunk_to_robot_p50_ms: {statistics.median(talk_ms):.1f}")
    print(f"talk_chunk_to_robot_p99_ms: {percentile(talk_ms, 99):.1f}")
    print(f"robot_mic_to_client_p99_ms: {percentile(mic_ms, 99):.1f}")
    print(f"talk_gap_pct: {gap_pct:.2f}")
    print(f"listen_clients_upstream_subscriptions: {upstream}")
    print(f"talk_quiet_cut_max_ms: {max(quiet_ms):.1f}")
    print(f"talk_disconnect_release_max_ms: {max(gone_ms):.1f}")
    print(f"mic_mp3_decode_per_chunk_us: {mp3_decode_us():.1f}")


if __name__ == "__main__":
    asyncio.run(main())
