"""'At location': the robot's word for its own places, the server's locations for the rest."""

from __future__ import annotations

import asyncio
import math

import pytest

from robot import interface as ri
from robot.live.groups import AT_LOCATION_KEY
from robot.models import Location
from robot.navigation.seeding import location_seed
from robot.navigation.whereabouts import location_at, settled_pose, track_whereabouts, whereabouts
from tests.helpers import wait_until
from tests.navigation.conftest import stored

PLACES = [("kitchen", 2.0, 0.0, 0.5), ("hall", 2.4, 0.0, 0.5), ("far", 10.0, 10.0, 0.5)]


def pose(x: float, y: float) -> dict:
    return {"position": {"x": x, "y": y, "z": 0.0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}


def test_it_picks_the_nearest_place_whose_radius_holds_the_pose():
    assert location_at(2.1, 0.0, PLACES) == "kitchen"
    assert location_at(2.3, 0.0, PLACES) == "hall"
    assert location_at(5.0, 5.0, PLACES) == ""
    assert location_at(2.0, 0.5, PLACES) == "kitchen"  # on the edge counts


def test_the_robots_own_answer_wins():
    assert whereabouts("reception", pose(2.0, 0.0), PLACES) == {"name": "reception", "source": "robot"}
    assert whereabouts("", pose(2.0, 0.0), PLACES) == {"name": "kitchen", "source": "server"}
    assert whereabouts("", None, PLACES) == {"name": "", "source": ""}



def test_a_place_the_robot_names_is_seeded_only_where_it_stayed_while_naming_it():
    assert settled_pose(None, ("reception", pose(1.0, 1.0))) is None  # once is not enough
    assert settled_pose(("reception", pose(1.0, 1.0)), ("reception", pose(1.1, 1.0))) == pose(1.1, 1.0)
    # A report older than the pose beside it: the robot had left (set down elsewhere) when it arrived.
    assert settled_pose(("reception", pose(1.0, 1.0)), ("reception", pose(-3.0, 0.0))) is None
    assert settled_pose(("", pose(1.0, 1.0)), ("reception", pose(1.0, 1.0))) is None
    assert settled_pose(("reception", pose(1.0, 1.0)), ("", pose(1.0, 1.0))) is None
    assert settled_pose(("reception", None), ("reception", pose(1.0, 1.0))) is None

@pytest.mark.django_db(transaction=True)
def test_it_says_where_the_robot_arrived_at_a_place_only_the_server_knows(sim, nav_link):
    tracker = asyncio.run_coroutine_threadsafe(track_whereabouts(nav_link), nav_link.dial.loop)
    try:
        # Away from every place of the robot's own, at a spot only the server has a name for.
        sim.call(lambda: sim.robot.base.teleport(-3.0, 0.0, 0.0))
        wait_until(lambda: sim.snapshot()["state"]["current_location"] == "", what="the robot to leave its places")
        Location.objects.create(name="workbench", x=-3.0, y=0.0, yaw=math.pi / 2, threshold=0.6)
        wait_until(lambda: (stored(AT_LOCATION_KEY) or {}).get("name") == "workbench", timeout=10,
                   what="the server to place the robot at the workbench")
        assert stored(AT_LOCATION_KEY) == {"name": "workbench", "source": "server"}
        # Back at one of its own places, the robot's answer is shown.
        sim.call(lambda: sim.robot.base.teleport(*_robot_place(sim, "reception")))
        wait_until(lambda: stored(AT_LOCATION_KEY) == {"name": "reception", "source": "robot"}, timeout=10,
                   what="the robot's own answer")
    finally:
        tracker.cancel()


@pytest.mark.django_db(transaction=True)
def test_a_place_the_robot_names_becomes_a_named_location_where_it_reported_being(sim, nav_link):
    Location.objects.filter(name="reception").delete()
    x, y, yaw = _robot_place(sim, "reception")
    sim.call(lambda: sim.robot.base.teleport(x, y, yaw))
    tracker = asyncio.run_coroutine_threadsafe(track_whereabouts(nav_link), nav_link.dial.loop)
    try:
        wait_until(lambda: Location.objects.filter(name="reception").exists(), timeout=10,
                   what="the robot's reception to be seeded")
        seeded = Location.objects.get(name="reception")
        assert math.hypot(seeded.x - x, seeded.y - y) < 0.3 and abs(math.remainder(seeded.yaw - yaw, math.tau)) < 0.2
        assert "robot" in seeded.description
        # Moved by an admin: the robot's word does not move it back.
        Location.objects.filter(name="reception").update(x=x + 1.0)
        sim.call(lambda: sim.robot.base.teleport(-3.0, 0.0, 0.0))
        sim.call(lambda: sim.robot.base.teleport(x, y, yaw))
        wait_until(lambda: stored(AT_LOCATION_KEY) == {"name": "reception", "source": "robot"}, timeout=10,
                   what="the robot back at reception")
        assert Location.objects.get(name="reception").x == pytest.approx(x + 1.0)
    finally:
        tracker.cancel()


def test_a_name_that_cannot_be_a_location_is_not_seeded(db):
    assert location_seed(name="the lobby!", pose=pose(1.0, 2.0)) is False
    assert location_seed(name="lobby", pose=pose(1.0, 2.0)) is True
    assert location_seed(name="lobby", pose=pose(5.0, 5.0)) is False
    assert (Location.objects.get(name="lobby").x, Location.objects.get(name="lobby").y) == (1.0, 2.0)


def _robot_place(sim, name: str) -> tuple[float, float, float]:
    loc = sim.robot.world.locations[name]
    return loc.x, loc.y, loc.yaw


def test_pages_watch_it():
    from robot.live.keys import HOME_KEYS, MAP_PAGE_KEYS, watchable_keys

    assert AT_LOCATION_KEY in HOME_KEYS and AT_LOCATION_KEY in MAP_PAGE_KEYS and AT_LOCATION_KEY in watchable_keys()
    assert ri.topic("current_location")  # still monitored: the robot's own answer comes from it
