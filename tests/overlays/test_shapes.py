"""Robot messages become map-frame shapes: frames composed right, rays placed right, junk left out."""

import math

import pytest

from robot.overlays.frames import FrameTree, Pose2D
from robot.overlays.shapes import particle_poses, path_points, polygon_points, scan_points


def tf(parent, child, x, y, yaw):
    return {"header": {"frame_id": parent}, "child_frame_id": child,
            "transform": {"translation": {"x": x, "y": y, "z": 0.0},
                          "rotation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}}


def pose(x, y, yaw):
    return {"position": {"x": x, "y": y, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}


def test_it_places_the_laser_through_the_static_transform_and_the_robot_pose():
    tree = FrameTree()
    tree.add_transforms({"transforms": [tf("base_link", "laser", 0.2, 0.0, 0.0)]})
    assert tree.in_map("laser") is None  # no pose yet
    tree.set_robot_pose(pose(1.0, 2.0, math.pi / 2))
    laser = tree.in_map("/laser")
    assert laser is not None
    assert (laser.x, laser.y) == pytest.approx((1.0, 2.2))
    assert laser.yaw == pytest.approx(math.pi / 2)


def test_it_places_odometry_through_tf_and_refuses_loops():
    tree = FrameTree()
    tree.add_transforms({"transforms": [tf("map", "odom", 1.0, 0.0, math.pi), tf("a", "b", 0, 0, 0),
                                        tf("b", "a", 0, 0, 0)]})
    odom = tree.in_map("odom")
    assert odom is not None and odom.apply(1.0, 0.0) == pytest.approx((0.0, 0.0))
    assert tree.in_map("a") is None
    assert tree.in_map("nowhere") is None
    assert tree.in_map("map") == Pose2D()


def test_a_scan_becomes_map_points_without_the_beams_that_saw_nothing():
    scan = {"angle_min": -math.pi / 2, "angle_increment": math.pi / 2, "range_min": 0.1, "range_max": 5.0,
            "ranges": [1.0, None, 2.0, 0.05, 9.0]}
    out = scan_points(scan, Pose2D(1.0, 1.0, math.pi / 2))
    # beam 0 points along the laser's -90 degrees: the map's +x; beam 2 along +90: the map's -x
    assert out["points"] == pytest.approx([2.0, 1.0, -1.0, 1.0])
    assert out["beams"] == 5 and out["origin"] == [1.0, 1.0]


def test_particles_paths_and_polygons_are_placed_and_thinned():
    cloud = {"poses": [pose(i * 0.01, 0.0, 0.0) for i in range(5000)]}
    out = particle_poses(cloud, Pose2D(0.0, 0.0, math.pi))
    assert out["count"] == 5000 and len(out["poses"]) // 3 <= 2000
    assert out["poses"][3:6] == pytest.approx([-0.03, 0.0, math.pi], abs=0.006)
    path = {"poses": [{"pose": pose(1.0, 0.0, 0.0)}, {"pose": pose(2.0, 0.0, 0.0)}]}
    assert path_points(path, Pose2D(0.0, 1.0, math.pi / 2))["points"] == pytest.approx([0.0, 2.0, 0.0, 3.0])
    polygon = {"polygon": {"points": [{"x": 1, "y": 0, "z": 0}, {"x": "junk"}, {"x": 0, "y": 1, "z": 0}]}}
    assert polygon_points(polygon, Pose2D(1.0, 1.0, 0.0))["points"] == [2.0, 1.0, 1.0, 2.0]
