"""The sonar overlay: the ring's echoes placed on the map from where the sonar frame is."""

from __future__ import annotations

import math

import pytest

from robot.overlays.frames import Pose2D
from robot.overlays.shapes import cloud_points


def test_echoes_are_placed_on_the_map_from_the_ring():
    ring = Pose2D(2.0, 1.0, math.pi / 2)  # facing +y on the map
    cloud = {"header": {"frame_id": "sonar"}, "points": [{"x": 1.0, "y": 0.0, "z": 0.0}, {"x": 0.0, "y": 2.0, "z": 0}],
             "channels": []}
    shape = cloud_points(cloud, ring)
    assert shape["origin"] == [2.0, 1.0] and shape["yaw"] == pytest.approx(math.pi / 2, abs=1e-3)
    assert shape["points"] == pytest.approx([2.0, 2.0, 0.0, 1.0])
    assert shape["ranges"] == [1.0, 2.0]


def test_malformed_or_endless_points_are_left_out():
    cloud = {"points": [{"x": None, "y": 0}, {"y": 1.0}, {"x": float("inf"), "y": 0}, {"x": 0.5, "y": 0.0}]}
    shape = cloud_points(cloud, Pose2D())
    assert shape["points"] == [0.5, 0.0] and shape["ranges"] == [0.5]
