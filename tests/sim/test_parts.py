"""The simulator's parts on their own: conversion rules, the state table, the world, the harness, the CLI."""

from __future__ import annotations

import base64
import itertools
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
from websockets.sync.client import connect

from robot import interface as ri
from simulator import SimThread, messages, world
from simulator.bus import Clock
from simulator.nodes import controller
from tests.sim.support import Raw, wait_until

ROOT = Path(__file__).resolve().parents[2]

# ROBOT_INTERFACE.md, "The state machine", written out again so a typo in the module shows up.
DOC_TOP = {
    "startup": {"succeeded": "suspension", "aborted": "suspension"},
    "suspension": {"behaviour_start": "behaviour", "restart": "startup", "demo_start": "demo",
                   "manual_start": "manual", "aborted": "suspension", "succeeded": "suspension"},
    "demo": {"succeeded": "suspension", "aborted": "suspension"},
    "manual": {"succeeded": "suspension", "aborted": "suspension"},
}
DOC_BEHAVIOUR = {
    "idle": {"suspend": "(leave)", "navigation_schedular": "navigation", "navigation_emotional": "navigation",
             "convey_emotion": "conveying_emotional_state", "show_off_mea": "show_off_mea",
             "music_play": "music_horror", "astrolanguage": "astrolanguage", "aborted": "idle",
             "power_low": "exhausted", "bedtime": "sleepy"},
    **{s: {"succeeded": "idle", "aborted": "idle"} for s in
       ("show_off_mea", "conveying_emotional_state", "music_horror", "astrolanguage", "waking_up")},
    "sleepy": {"aborted": "idle", "succeeded": "sleeping"},
    "exhausted": {"aborted": "idle", "succeeded": "sleeping"},
    "sleeping": {"preempted": "idle", "cyborg_wake_up": "waking_up"},
    "navigation": {"succeeded": "idle", "aborted": "idle", "power_low": "exhausted"},
}


def _observable(state: str) -> str:
    if state in controller.NAVIGATION_LEAVES:
        return "navigation"
    return state


@pytest.mark.parametrize("state", list(DOC_TOP) + list(DOC_BEHAVIOUR))
def test_it_implements_every_transition_of_the_documented_table(state):
    doc = DOC_TOP.get(state) or DOC_BEHAVIOUR[state]
    leaf = "navigation_go_to_schedular" if state == "navigation" else state
    for event, expected in doc.items():
        machine = controller.StateMachine(lambda *a: None, initial=leaf)
        assert machine.fire(event), (state, event)
        reached = machine.state
        if expected == "behaviour":
            assert reached == "idle" and machine.top == "behaviour"
        elif expected == "(leave)":
            assert reached == "suspension"
        else:
            assert _observable(reached) == expected, (state, event, reached)
    machine = controller.StateMachine(lambda *a: None, initial=leaf)
    assert not machine.fire("no_such_event") and machine.state == leaf


def test_it_lists_the_behaviour_states_in_the_interface_registry():
    assert frozenset(ri.BEHAVIOUR_STATES) == controller.BEHAVIOUR_STATES


def test_it_converts_messages_with_rosbridge_rules():
    img = messages.normalize("sensor_msgs/CompressedImage", {"format": "jpeg", "data": [255, 216, 0]})
    assert base64.b64decode(img["data"]) == b"\xff\xd8\x00"
    assert messages.normalize("sensor_msgs/CompressedImage", {"data": "/9g="})["data"] == "/9g="
    with pytest.raises(messages.ConversionError, match="requires a int32"):
        messages.normalize("std_msgs/Int32", {"data": 1.0})
    with pytest.raises(messages.ConversionError, match="requires a bool"):
        messages.normalize("std_msgs/Bool", {"data": 1})
    with pytest.raises(messages.ConversionError, match="must have 36 elements"):
        messages.normalize("geometry_msgs/PoseWithCovariance", {"covariance": [0.0]})
    assert messages.normalize("std_msgs/Float32", {"data": 3}) == {"data": 3.0}
    goal = messages.normalize("move_base_msgs/MoveBaseActionGoal", {"goal": {}})
    assert goal["goal"]["target_pose"]["pose"]["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}
    assert messages.encode({"x": math.inf, "y": [math.nan]}) == '{"x":null,"y":[null]}'


def test_it_builds_the_same_glassgarden_map_every_time():
    a, b = world.build("glassgarden"), world.build("glassgarden", seed=5)
    assert (a.width, a.height, a.resolution) == (400, 300, 0.05)
    assert (a.grid == b.grid).all()
    assert {-1, 0, 100} == set(a.grid.ravel().tolist())
    for loc in a.locations.values():
        assert a.footprint_free(loc.x, loc.y), loc.name
    assert a.footprint_free(*a.start[:2])


def test_it_plans_across_the_hall_quickly_and_around_obstacles():
    w = world.build("glassgarden")
    planner = world.Planner(w)
    start, goal = w.locations["charging_station"], w.locations["elevator"]
    t0 = time.perf_counter()
    path = planner.plan((start.x, start.y), (goal.x, goal.y))
    assert time.perf_counter() - t0 < 1.0
    assert path is not None and path[-1] == (goal.x, goal.y)
    for (x0, y0), (x1, y1) in itertools.pairwise(path):
        for k in range(5):
            assert not w.occupied(x0 + (x1 - x0) * k / 5, y0 + (y1 - y0) * k / 5)
    assert planner.plan((0.0, -1.0), (6.0, 1.0)) is None  # inside a pillar


def test_it_builds_and_plans_on_the_large_map():
    w = world.build("large")
    assert (w.width, w.height) == (4000, 4000)
    planner = world.Planner(w)
    t0 = time.perf_counter()
    far = w.locations["far_corner"]
    assert planner.plan(w.start[:2], (far.x, far.y)) is not None
    assert time.perf_counter() - t0 < 3.0


def test_it_restarts_on_the_same_port_and_clients_see_the_drop():
    first = SimThread(startup_s=0.1).start()
    port = first.port
    client = Raw(first.url)
    wait_until(lambda: first.snapshot()["clients"] == 1)
    t0 = time.monotonic()
    first.stop()
    assert client.closed.wait(2.0) and time.monotonic() - t0 < 3.0
    with SimThread(port=port, startup_s=0.1) as second:
        assert second.port == port
        with connect(second.url) as ws:
            ws.send('{"op": "call_service", "service": "/rosapi/get_time", "id": "t"}')
            assert '"result":true' in ws.recv(timeout=5)


def test_it_runs_from_its_command_line():
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "simulator", "--port", "0", "--video-port", "0", "--startup-s", "0.2",
         "--pose-rate", "5"], cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        match = re.search(r"Simulator listening on (ws://\S+)", line)
        assert match, line
        with connect(match.group(1)) as ws:
            ws.send('{"op": "call_service", "service": "/rosapi/nodes", "id": "n"}')
            assert "/rosbridge_websocket" in ws.recv(timeout=5)
        proc.terminate()
        assert proc.wait(10) == 0
    finally:
        proc.kill()


def test_it_lets_roslibpy_reconnect_and_resubscribe_after_a_restart_on_the_same_port():
    import roslibpy

    first = SimThread(startup_s=0.1).start()
    port = first.port
    ros = roslibpy.Ros(first.host, port)
    ros.run(timeout=10)
    try:
        roslibpy.Topic(ros, ri.topic("robot_pose").name, ri.topic("robot_pose").type).subscribe(lambda m: None)
        wait_until(lambda: first.subscription_count(ri.topic("robot_pose").name) == 1)
        first.stop()
        with SimThread(port=port, startup_s=0.1) as second:
            wait_until(lambda: second.subscription_count(ri.topic("robot_pose").name) == 1, timeout=10,
                       what="roslibpy re-subscribed")
    finally:
        ros.close()


def test_a_scaled_clock_runs_the_worlds_time_that_many_times_as_fast():
    clock = Clock(scale=8.0)
    host_before, world_before = time.monotonic(), clock.now()
    time.sleep(0.05)
    world_after, host_after = clock.now(), time.monotonic()
    assert 8.0 * 0.05 <= world_after - world_before <= 8.0 * (host_after - host_before)
    with pytest.raises(ValueError):
        Clock(scale=0)


def test_a_scaled_world_ends_its_timers_sooner_in_the_hosts_time():
    # Start-up takes 4 s of the world's time: at 8 times the pace, well under the 2 s waited here.
    with SimThread(startup_s=4.0, time_scale=8.0) as sim:
        wait_until(lambda: sim.snapshot()["state"]["smach_state"] == "suspension", timeout=2.0,
                   what="start-up to end at the world's pace")
