"""The link's last word on cmd_vel, on its own: a stop that cannot reach the robot still latches
and says so, the deadman fires once for a stream that went quiet, and the latch refuses by content."""

from __future__ import annotations

import asyncio
import logging

from robot import interface as ri
from robot.link.guard import RELEASE_FIRST, CmdVelGuard

FORWARD = {"linear": {"x": 0.3, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}


def guard(publish_zero) -> CmdVelGuard:
    return CmdVelGuard(publish_zero, loop=asyncio.get_running_loop(), rate_hz=20, hold_s=0.2, deadman_s=0.1)


async def test_an_estop_the_robot_cannot_hear_still_latches_and_is_logged(caplog):
    def offline() -> None:
        raise RuntimeError("robot offline")

    stop = guard(offline)
    with caplog.at_level(logging.WARNING, logger="robot.link.guard"):
        stop.engage()
    assert stop.latched and "could not publish a zero Twist: robot offline" in caplog.text
    assert stop.check(FORWARD) is not None  # motion refused all the same
    stop.stop()


async def test_the_deadman_sends_one_zero_when_a_moving_stream_goes_quiet():
    zeros: list[float] = []
    stop = guard(lambda: zeros.append(1.0))
    assert stop.check(FORWARD, fresh_press=True) is None
    await asyncio.sleep(0.3)
    assert zeros == [1.0] and not stop.moving
    stop.stop()


async def test_under_the_latch_only_what_stops_passes_and_the_stops_own_walk_only_from_it():
    stop = guard(lambda: None)
    stop.engage()
    event = ri.topic("register_event").name
    assert stop.check_publish(event, {"data": "aborted"}) is not None
    assert stop.check_publish(event, {"data": "aborted"}, by_the_stop=True) is None
    assert stop.check_publish(event, {"data": "demo_start"}, by_the_stop=True) is not None
    assert stop.check_publish(ri.topic("text_to_speech").name, {"data": "hi"}) is None
    assert stop.check_publish(ri.service("enable_motors").name, {}, by_the_stop=True) is not None
    assert stop.check_publish(ri.service("disable_motors").name, {}) is None
    stop.release()
    assert stop.check_publish(event, {"data": "demo_start"}) is None
    stop.stop()


async def test_a_new_link_moves_the_robot_only_for_a_fresh_press():
    """It may be taking over from a link that was lost while a key was held (a failover, a restart)."""
    stop = guard(lambda: None)
    assert stop.check(FORWARD) == RELEASE_FIRST
    assert stop.check(FORWARD, fresh_press=True) is None
    assert stop.check(FORWARD) is None  # the press goes on
    stop.stop()


async def test_after_a_lost_connection_motion_waits_for_a_zero():
    stop = guard(lambda: None)
    assert stop.check(FORWARD, fresh_press=True) is None
    stop.lost()  # a key was held when the connection dropped
    assert not stop.moving
    assert stop.check(FORWARD) == RELEASE_FIRST  # the held key, after the reconnect: refused
    assert stop.check(ri.ZERO_TWIST) is None  # the driver let go
    assert stop.check(FORWARD) is None  # and pressed again
    stop.lost()
    assert stop.check(FORWARD, fresh_press=True) is None  # a driver who was not holding a key then
    stop.stop()
