import io

import numpy as np
import pytest
from PIL import Image

from robot.navigation.mapimage import (
    FREE_RGB,
    OCCUPIED_RGB,
    UNKNOWN_RGB,
    MapError,
    cell_value,
    is_version,
    render_map,
)
from robot.navigation.transforms import yaw_to_quaternion


def grid_message(grid: np.ndarray, resolution: float = 0.5, origin=(-1.0, -2.0)) -> dict:
    h, w = grid.shape
    return {"header": {"frame_id": "map"}, "info": {
        "resolution": resolution, "width": w, "height": h,
        "origin": {"position": {"x": origin[0], "y": origin[1], "z": 0.0}, "orientation": yaw_to_quaternion(0.0)}},
        "data": grid.ravel().tolist()}


def sample_grid() -> np.ndarray:
    grid = np.zeros((3, 4), dtype=np.int8)
    grid[0, 0] = 100  # bottom-left cell of the map
    grid[2, 3] = -1  # top-right cell
    grid[1, 2] = 50
    return grid


def test_it_renders_the_grid_with_y_flipped_and_three_shades(tmp_path):
    rendered = render_map(grid_message(sample_grid()), tmp_path)
    image = Image.open(io.BytesIO(rendered.png.read_bytes())).convert("RGB")
    assert image.size == (4, 3)
    assert image.getpixel((0, 2)) == OCCUPIED_RGB  # grid row 0 is the image's bottom row
    assert image.getpixel((3, 0)) == UNKNOWN_RGB
    assert image.getpixel((1, 1)) == FREE_RGB
    mid = image.getpixel((2, 1))
    assert all(min(a, b) < c < max(a, b) for a, b, c in zip(FREE_RGB, OCCUPIED_RGB, mid, strict=True))


def test_it_renders_each_version_once(tmp_path):
    first = render_map(grid_message(sample_grid()), tmp_path)
    mtime = first.png.stat().st_mtime_ns
    again = render_map(grid_message(sample_grid()), tmp_path)
    assert again.version == first.version and again.cached and not first.cached
    assert again.png.stat().st_mtime_ns == mtime
    changed = sample_grid()
    changed[1, 1] = 100
    other = render_map(grid_message(changed), tmp_path)
    moved = render_map(grid_message(sample_grid(), origin=(0.0, 0.0)), tmp_path)
    assert len({first.version, other.version, moved.version}) == 3
    assert all(is_version(v) for v in (first.version, other.version, moved.version))


def test_it_keeps_the_cells_for_validation(tmp_path):
    rendered = render_map(grid_message(sample_grid()), tmp_path)
    assert cell_value(tmp_path, rendered.version, 0, 0) == 100
    assert cell_value(tmp_path, rendered.version, 2, 3) == -1
    assert cell_value(tmp_path, rendered.version, 1, 1) == 0
    assert cell_value(tmp_path, "0" * 20, 0, 0) is None


def test_it_refuses_a_grid_whose_size_does_not_match(tmp_path):
    msg = grid_message(sample_grid())
    msg["data"] = msg["data"][:-1]
    with pytest.raises(MapError):
        render_map(msg, tmp_path)
    assert not list(tmp_path.iterdir())


def test_it_keeps_only_the_latest_few_versions(tmp_path):
    versions = []
    for k in range(7):
        grid = sample_grid()
        grid[1, 0] = k
        versions.append(render_map(grid_message(grid), tmp_path).version)
    on_disk = {p.stem for p in tmp_path.glob("*.png")}
    assert versions[-1] in on_disk and len(on_disk) <= 4
    assert {p.stem for p in tmp_path.glob("*.npy")} == on_disk
