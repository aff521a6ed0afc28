import math

import pytest

from robot.navigation.transforms import (
    MapGeometry,
    map_bounds,
    map_to_cell,
    map_to_pixel,
    normalize_angle,
    pixel_to_map,
    quaternion_to_yaw,
    yaw_to_quaternion,
)

GLASSGARDEN = MapGeometry(width=400, height=300, resolution=0.05, origin_x=-10.0, origin_y=-7.5)
ROTATED = MapGeometry(width=120, height=80, resolution=0.1, origin_x=3.0, origin_y=-2.0, origin_yaw=0.7)
POINTS = [(-10.0, -7.5), (0.0, 0.0), (9.99, 7.49), (-3.21, 4.56), (12.0, -9.0)]


@pytest.mark.parametrize("geometry", [GLASSGARDEN, ROTATED])
@pytest.mark.parametrize(("x", "y"), POINTS)
def test_it_round_trips_map_to_pixel_and_back(geometry, x, y):
    px, py = map_to_pixel(geometry, x, y)
    assert pixel_to_map(geometry, px, py) == pytest.approx((x, y), abs=1e-9)


@pytest.mark.parametrize("geometry", [GLASSGARDEN, ROTATED])
@pytest.mark.parametrize(("px", "py"), [(0, 0), (0.5, 0.5), (399.5, 12.25), (17, 299), (-4, 500)])
def test_it_round_trips_pixel_to_map_and_back(geometry, px, py):
    x, y = pixel_to_map(geometry, px, py)
    assert map_to_pixel(geometry, x, y) == pytest.approx((px, py), abs=1e-9)


def test_it_puts_the_origin_at_the_image_bottom_left_and_flips_y():
    assert map_to_pixel(GLASSGARDEN, -10.0, -7.5) == pytest.approx((0.0, 300.0))
    assert map_to_pixel(GLASSGARDEN, 10.0, 7.5) == pytest.approx((400.0, 0.0))
    # Going up the map (ROS +y) goes up the image (smaller image y).
    _, low = map_to_pixel(GLASSGARDEN, 0.0, -1.0)
    _, high = map_to_pixel(GLASSGARDEN, 0.0, 1.0)
    assert high < low and low - high == pytest.approx(2.0 / 0.05)


def test_it_rotates_with_the_origin_yaw():
    g = MapGeometry(width=10, height=10, resolution=1.0, origin_x=0.0, origin_y=0.0, origin_yaw=math.pi / 2)
    # The grid's +x (columns) points along the map's +y.
    assert map_to_pixel(g, 0.0, 3.0) == pytest.approx((3.0, 10.0))


def test_it_finds_the_cell_of_a_point_and_none_off_the_map():
    assert map_to_cell(GLASSGARDEN, -10.0, -7.5) == (0, 0)
    assert map_to_cell(GLASSGARDEN, -9.951, -7.449) == (1, 0)
    assert map_to_cell(GLASSGARDEN, 9.999, 7.499) == (299, 399)
    assert map_to_cell(GLASSGARDEN, 10.0, 0.0) is None
    assert map_to_cell(GLASSGARDEN, 0.0, -7.6) is None
    assert map_to_cell(GLASSGARDEN, math.nan, 0.0) is None


def test_it_reports_the_map_bounds():
    assert map_bounds(GLASSGARDEN) == pytest.approx((-10.0, -7.5, 10.0, 7.5))


def test_it_reads_geometry_from_an_occupancy_grid_info():
    info = {"width": 400, "height": 300, "resolution": 0.05,
            "origin": {"position": {"x": -10.0, "y": -7.5, "z": 0.0}, "orientation": yaw_to_quaternion(0.0)}}
    assert MapGeometry.from_info(info) == GLASSGARDEN


@pytest.mark.parametrize("yaw", [0.0, 0.3, -1.2, math.pi - 1e-6, -math.pi + 1e-6, 2.5])
def test_it_round_trips_yaw_through_a_quaternion(yaw):
    q = yaw_to_quaternion(yaw)
    assert q["x"] == q["y"] == 0.0
    assert math.hypot(q["z"], q["w"]) == pytest.approx(1.0)
    assert quaternion_to_yaw(q) == pytest.approx(yaw)


def test_it_treats_an_all_zero_quaternion_as_no_rotation():
    assert quaternion_to_yaw({"x": 0, "y": 0, "z": 0, "w": 0}) == 0.0


def test_it_normalizes_angles():
    assert normalize_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert normalize_angle(-7.0) == pytest.approx(-7.0 + 2 * math.pi)
