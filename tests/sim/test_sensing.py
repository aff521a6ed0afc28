"""The simulator's laser, costmaps, particle cloud, footprint and local plan agree with its world."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from robot import interface as ri
from simulator.harness import SimThread
from simulator.nodes.laser import Laser
from simulator.world import OCCUPIED, UNKNOWN, WorldMap, build
from tests.sim.support import Raw, on_topic


def subscribe(raw: Raw, key: str) -> str:
    t = ri.topic(key)
    raw.send({"op": "subscribe", "topic": t.name, "type": t.type})
    return t.name


def march(world: WorldMap, x: float, y: float, angle: float, max_range: float) -> float:
    """A slow, fine ray march (5 mm steps) as the reference for the fast caster."""
    for d in np.arange(0.005, max_range, 0.005):
        r, c = world.cell(x + d * math.cos(angle), y + d * math.sin(angle))
        if 0 <= r < world.height and 0 <= c < world.width and world.grid[r, c] >= OCCUPIED:
            return float(d)
    return math.nan


@pytest.mark.parametrize("name, poses", [
    ("glassgarden", [(0.0, -1.0, math.pi / 2), (2.5, 0.0, 0.3), (-7.0, 2.0, -2.0)]),
    ("large", [(-95.0, -95.0, 0.0), (-7.0, 2.0, -2.0)]),  # coarse distance blocks on a 4000 x 4000 grid
])
def test_the_laser_sees_the_walls_and_pillars_where_a_fine_ray_march_does(name, poses) -> None:
    world = build(name)
    laser = Laser(world)
    for pose in poses:
        lx, ly, lyaw = laser.pose_on(*pose)
        ranges = laser.ranges(*pose)
        assert ranges.size == 541 and np.isfinite(ranges).sum() > 100
        for i in range(0, 541, 9):
            angle = lyaw + laser.angle_min + i * laser.angle_increment
            expected = march(world, lx, ly, angle, laser.range_max)
            if math.isnan(expected):
                assert math.isnan(ranges[i]), (pose, i, ranges[i])
            else:
                assert abs(ranges[i] - expected) <= world.resolution, (pose, i, ranges[i], expected)


def test_the_scan_goes_out_at_its_rate_with_null_for_no_return(sim: SimThread, raw_client: Callable[[], Raw]) -> None:
    raw = raw_client()
    name = subscribe(raw, "scan")
    frames = raw.collect(1.05, on_topic(name))
    assert 8 <= len(frames) <= 12  # 10 Hz
    msg = frames[-1]["msg"]
    assert msg["header"]["frame_id"] == "laser" and len(msg["ranges"]) == 541
    assert None in msg["ranges"]  # beams out through the doors see nothing within 10 m
    assert msg["angle_min"] + 540 * msg["angle_increment"] == pytest.approx(msg["angle_max"])


def test_the_global_costmap_inflates_the_world_and_updates_the_window_around_the_robot(
        sim: SimThread, raw_client: Callable[[], Raw]) -> None:
    raw = raw_client()
    full = raw.expect(on_topic(subscribe(raw, "global_costmap")), timeout=5)["msg"]
    world = sim.robot.world
    assert (full["info"]["width"], full["info"]["height"]) == (world.width, world.height)
    cells = np.array(full["data"], dtype=np.int8).reshape(world.height, world.width)
    assert (cells[world.grid >= OCCUPIED] == 100).all()
    assert (cells[world.grid == UNKNOWN] == -1).all()
    # within the inscribed radius (0.25 m) of a wall: 99; farther out the cost falls; 0.6 m away: free
    r, c = world.cell(3.0, -6.85 + 0.125)  # 12.5 cm in front of the south wall
    assert cells[r, c] == 99
    near, far, free = cells[world.cell(3.0, -6.85 + 0.35)], cells[world.cell(3.0, -6.85 + 0.5)], \
        cells[world.cell(3.0, -6.85 + 0.7)]
    assert 99 > near > far > 0 and free == 0
    # a second client gets the whole costmap at once (costmap_2d sends it to each new subscriber)
    other = raw_client()
    assert other.expect(on_topic(subscribe(other, "global_costmap")), timeout=5)["msg"]["data"] == full["data"]
    update = raw.expect(on_topic(subscribe(raw, "global_costmap_updates")), timeout=5)["msg"]
    b = sim.robot.base
    x0 = world.origin_x + update["x"] * world.resolution
    y0 = world.origin_y + update["y"] * world.resolution
    assert x0 <= b.x <= x0 + update["width"] * world.resolution
    assert y0 <= b.y <= y0 + update["height"] * world.resolution
    patch = np.array(update["data"], dtype=np.int8).reshape(update["height"], update["width"])
    window = cells[update["y"]:update["y"] + update["height"], update["x"]:update["x"] + update["width"]]
    assert (patch == window).all()  # the static world: what the sensors see agrees with the map


def test_the_local_costmap_rolls_with_the_robot_in_the_odometry_frame(sim: SimThread, raw_client) -> None:
    raw = raw_client()
    full = raw.expect(on_topic(subscribe(raw, "local_costmap")), timeout=5)["msg"]
    assert full["header"]["frame_id"] == "odom" and full["info"]["width"] == full["info"]["height"] == 80
    update = raw.expect(on_topic(subscribe(raw, "local_costmap_updates")), timeout=5)["msg"]
    assert (update["x"], update["y"], update["width"], update["height"]) == (0, 0, 80, 80)
    b = sim.robot.base
    info = full["info"]["origin"]["position"]
    # the window is centred on the robot's odometry position
    assert abs(info["x"] + 2.0 - b.odom_x) <= 0.05 and abs(info["y"] + 2.0 - b.odom_y) <= 0.05
    assert 100 in full["data"]  # the pillar row 2 m ahead of the start pose


def test_the_particle_cloud_spreads_after_an_initial_pose_and_then_tightens(sim: SimThread, raw_client) -> None:
    raw = raw_client()
    name = subscribe(raw, "particlecloud")
    raw.expect(on_topic(name), timeout=5)
    t = ri.topic("initialpose")
    cov = [0.0] * 36
    raw.send({"op": "publish", "topic": t.name, "msg": {"header": {"frame_id": "map"}, "pose": {
        "pose": {"position": {"x": 1.0, "y": -2.0, "z": 0.0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}},
        "covariance": cov}}})

    def spread() -> float:
        poses = raw.expect(on_topic(name), timeout=5)["msg"]["poses"]
        xs = np.array([[p["position"]["x"], p["position"]["y"]] for p in poses])
        assert abs(xs[:, 0].mean() - 1.0) < 0.15 and abs(xs[:, 1].mean() + 2.0) < 0.15
        return float(xs.std(axis=0).mean())

    raw.collect(0.6)  # what was published before the pose was set
    first = spread()
    assert 0.3 < first < 0.7  # amcl's initial covariance: 0.5 m
    raw.collect(3.0)
    assert spread() < first * 0.6


def test_the_footprint_follows_the_robot_and_the_local_plan_appears_while_navigating(
        sim: SimThread, raw_client) -> None:
    raw = raw_client()
    footprint = raw.expect(on_topic(subscribe(raw, "footprint")), timeout=5)["msg"]
    corners = np.array([[p["x"], p["y"]] for p in footprint["polygon"]["points"]])
    b = sim.robot.base
    assert footprint["header"]["frame_id"] == "map" and len(corners) == 4
    assert np.allclose(corners.mean(axis=0), [b.x, b.y], atol=0.01)
    sides = np.linalg.norm(np.diff(np.vstack([corners, corners[:1]]), axis=0), axis=1)
    assert sorted(np.round(sides, 2)) == [0.5, 0.5, 0.7, 0.7]
    plan_name = subscribe(raw, "local_plan")
    assert not raw.collect(0.5, on_topic(plan_name))  # standing still: no local plan
    goal = ri.topic("move_base_simple_goal")
    raw.send({"op": "publish", "topic": goal.name, "msg": {"header": {"frame_id": "map"}, "pose": {
        "position": {"x": 3.0, "y": -1.0, "z": 0.0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}}})
    plan = raw.expect(lambda f: on_topic(plan_name)(f) and len(f["msg"]["poses"]) > 5, timeout=10)["msg"]
    assert plan["header"]["frame_id"] == "odom"
    start = plan["poses"][0]["pose"]["position"]
    assert math.hypot(start["x"] - sim.robot.base.odom_x, start["y"] - sim.robot.base.odom_y) < 0.3
