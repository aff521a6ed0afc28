"""Navigation fixtures: a private map folder, and a robot link that also runs the goal tracker."""

from __future__ import annotations

import asyncio
import contextlib

import pytest

from robot.live.groups import GOAL_KEY, GOAL_STATUS_KEY, MAP_META_KEY
from robot.live.state import get_store
from robot.navigation.handlers import track_goal_statuses
from tests.conftest import LinkThread
from tests.helpers import wait_until


@pytest.fixture(autouse=True)
def _private_var_dir(settings, tmp_path):
    settings.VAR_DIR = tmp_path


@pytest.fixture
def sim(request):
    """The simulator with its world at 4 times the pace: goals are reached in a quarter of the time.
    Parametrize it (indirect) with 2 for a ROS 2 robot."""
    from simulator.harness import SimThread

    ros = getattr(request, "param", 1)
    with SimThread(port=0, video_port=0, startup_s=0.5, time_scale=4.0, ros=ros) as running:
        yield running


EITHER_ROS = pytest.mark.parametrize("sim", [1, 2], indirect=True, ids=["ros1", "ros2"])


@contextlib.contextmanager
def linked(sim, settings):
    """The link to ``sim`` and its goal-status tracker (not the other background services), once the map arrived."""
    settings.ROSBRIDGE_URL = sim.url
    runner = LinkThread()
    runner.start()
    tracker = asyncio.run_coroutine_threadsafe(track_goal_statuses(runner.link), runner.loop)
    try:
        wait_until(lambda: runner.link.dial.ros_version == sim.robot.ros, timeout=10, what="the link to find the ROS")
        wait_until(lambda: stored(MAP_META_KEY), timeout=10, what="the map to be rendered")
        yield runner.link
    finally:
        tracker.cancel()
        runner.stop()


@pytest.fixture
def nav_link(sim, settings):
    with linked(sim, settings) as link:
        yield link


def stored(key: str):
    entry = get_store().get_all().get(key)
    return entry["msg"] if entry else None


def goal_state(client) -> str | None:
    goal = client.get("/api/navigation/status/").json()["goal"]
    return goal["status"] if goal else None


def wait_goal_state(client, *states: str, timeout: float = 20.0) -> str:
    return wait_until(lambda: (s := goal_state(client)) in states and s, timeout=timeout,
                      what=f"goal status in {states}")


__all__ = ["EITHER_ROS", "GOAL_KEY", "GOAL_STATUS_KEY", "MAP_META_KEY", "goal_state", "linked", "stored",
           "wait_goal_state"]
