"""Sustained history ingest: 98 every-message topics through the recorder into SQLite and PostgreSQL.

The thesis recorded the robot's 98 topics into MongoDB Atlas and hit its ~100 writes/s cap.
Here the recorder's link listener (``Recorder.offer``) is called directly on an event loop,
the way the robot link calls it, at up to 60,000 messages/s: messages of four realistic shapes spread
over 98 topics; the recorder batches them and writes from its worker thread. The figure is
stored messages per second from the first message offered to the last one committed, and
the loss check compares the stored row count with the number offered (target: >= 20,000/s,
zero loss). Not through websockets: this measures the recorder and the database.

Run: .venv/bin/python bench/history_ingest.py
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _history_db import run_per_backend, setup_child

TOPICS = 98
PER_TOPIC = 2500  # 245,000 messages per backend
OFFER_RATE = 60_000  # messages/s offered, above the 20,000/s target, so the database sets the pace


def _shapes(i: int) -> tuple[str, dict]:
    shapes = [
        ("std_msgs/Float32", {"data": i * 0.001}),
        ("std_msgs/String", {"data": f"State transition {i}: idle --[behaviour_start]--> behaviour"}),
        ("geometry_msgs/Pose", {"position": {"x": i * 0.01, "y": -i * 0.02, "z": 0.0},
                                "orientation": {"x": 0.0, "y": 0.0, "z": 0.38, "w": 0.92}}),
        ("cyborg_controller/EmotionalState", {"from_emotional_state": "curious", "to_emotional_state": "elated",
                                              "current_pleasure": 0.5, "current_arousal": 0.42,
                                              "current_dominance": 0.23}),
    ]
    return shapes[i % len(shapes)]


def child() -> None:
    setup_child()
    import asyncio

    from history.models import Mode, Sample, TopicPolicy
    from history.policies import load_policies
    from history.recorder import Recorder

    topics = [(f"/bench/topic_{n:02d}", _shapes(n)) for n in range(TOPICS)]
    TopicPolicy.objects.bulk_create(TopicPolicy(topic=name, msg_type=shape[0], mode=Mode.EVERY)
                                    for name, shape in topics)
    total = TOPICS * PER_TOPIC
    rec = Recorder()  # the server's settings: 0.5 s flushes, 5,000-row batches, 200,000-row buffer
    rec.apply(load_policies())

    async def drive() -> float:
        flusher_done = asyncio.Event()

        async def flusher() -> None:
            while rec.stored < total:
                await asyncio.sleep(rec.flush_s)
                await rec.flush()
            flusher_done.set()

        task = asyncio.ensure_future(flusher())
        start = time.perf_counter()
        for round_ in range(PER_TOPIC):
            for name, (msg_type, msg) in topics:
                rec.offer(name, msg_type, dict(msg), time.time())
            # Offer at OFFER_RATE at most, as a robot would publish: a steady stream, not one lump.
            ahead = (round_ + 1) * TOPICS / OFFER_RATE - (time.perf_counter() - start)
            if ahead > 0 or round_ % 10 == 0:
                await asyncio.sleep(max(ahead, 0))
        await flusher_done.wait()
        elapsed = time.perf_counter() - start
        await task
        return elapsed

    elapsed = asyncio.run(drive())
    stored = Sample.objects.count()
    print(json.dumps({"offered": total, "stored": stored, "seconds": elapsed, "dropped": rec.dropped}))


def main() -> None:
    results = run_per_backend(__file__)
    print(f"topics: {TOPICS}")
    for name, r in results.items():
        print(f"{name}_recorder_msgs_per_s: {r['stored'] / r['seconds']:.0f}")
        print(f"{name}_messages_offered: {r['offered']}")
        print(f"{name}_lost_messages: {r['offered'] - r['stored']}")
        print(f"{name}_dropped_by_recorder: {r['dropped']}")


if __name__ == "__main__":
    child() if "--child" in sys.argv else main()
