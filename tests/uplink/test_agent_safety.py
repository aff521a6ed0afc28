"""The agent's deadman and its measure of how late a server-stamped message is, without a network."""

from __future__ import annotations

import asyncio
import json

from uplink_agent import mux
from uplink_agent.safety import Deadman, Lateness


class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


class Guard:
    def __init__(self) -> None:
        self.zeros = 0

    def publish_zero(self) -> bool:
        self.zeros += 1
        return True


def test_lateness_is_the_wait_beyond_the_fastest_trip_whatever_the_clocks_offset() -> None:
    clock = Clock()
    lateness = Lateness(window_s=60, clock=clock)
    offset = 5000.0  # the server's clock is far from the agent's
    for delay in (0.03, 0.02, 0.025):
        clock.now += 0.05
        lateness.late(clock.now - offset - delay)
    clock.now += 0.05
    assert abs(lateness.late(clock.now - offset - 0.02)) < 1e-9
    clock.now += 0.05
    assert abs(lateness.late(clock.now - offset - 1.02) - 1.0) < 1e-9  # it waited a second in a stall


def test_lateness_follows_a_drifting_clock_once_the_window_has_passed() -> None:
    clock = Clock()
    lateness = Lateness(window_s=10, clock=clock)
    lateness.late(clock.now - 0.02)
    for _ in range(300):  # the server's clock loses 10 ms a second, for 30 s: 0.3 s in all
        clock.now += 0.1
        late = lateness.late(clock.now - 0.02 - 0.01 * (clock.now - 1000.0))
    assert 0.0 < late < 0.15  # only the drift within the window counts


def _publish(x: float) -> bytes:
    return json.dumps({"op": "publish", "topic": "/cmd_vel",
                       "msg": {"linear": {"x": x, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": 0}}}).encode()


def test_a_stale_move_is_held_back_a_stale_stop_and_anything_else_go_on() -> None:
    loop = asyncio.new_event_loop()
    try:
        deadman = Deadman("/cmd_vel", 0.4, Guard(), loop=loop)
        assert deadman.passes(_publish(0.3), late=0.01) and deadman.driving
        assert not deadman.passes(_publish(0.3), late=0.5)
        assert deadman.stale_dropped == 1
        assert deadman.passes(_publish(0.0), late=2.0) and not deadman.driving
        assert deadman.passes(b'{"op": "subscribe", "topic": "/odom"}', late=5.0)
        assert deadman.passes(json.dumps({"op": "publish", "topic": "/other", "msg": {}}).encode(), late=5.0)
    finally:
        loop.close()


def test_a_stamped_frame_carries_its_stamp_and_its_message() -> None:
    kind, channel, payload = mux.decode(mux.encode_stamped(7, 1234.5, b"{}"))
    assert (kind, channel) == (mux.STAMPED, 7)
    assert mux.split_stamp(payload) == (1234.5, b"{}")
